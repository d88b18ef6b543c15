#include "server/query/query_service.h"

#include <gtest/gtest.h>

#include "tests/server/estimator/camera_test_messages.h"

namespace slamd::server {
namespace {

using core::Pose2;

core::NoiseModel Noise(int dim, double sigma) {
  return core::NoiseModel::Isotropic(dim, sigma).value();
}

// Two robots; r has a landmark. Reference values: the chain's poses and the covariances of a
// prior (sigma 0.01) followed by identity odometry (sigma 0.1).
std::unique_ptr<Estimator> TwoRobots() {
  core::Isam2Params isam2;
  auto e = Estimator::Create({}, isam2).value();
  std::vector<Inbound> msgs;
  for (const char* robot : {"r", "s"}) {
    msgs.push_back({PriorMeasurement{1, robot, 0, PriorKind::kPose2, Pose2(), Noise(3, 0.01)}, 0});
    for (std::uint64_t i = 0; i < 3; ++i) {
      msgs.push_back({OdometryMeasurement{2, robot, i, i + 1, Pose2(), Noise(3, 0.1)}, 0});
    }
  }
  msgs.push_back({LandmarkMeasurement{3, "r", 2, 9, LandmarkKind::kRelativePoint2,
                                      core::Point2(1, 0), Noise(2, 0.1)},
                  0});
  SLAMD_CHECK(e->Process(msgs).status.ok());
  return e;
}

TEST(QueryServiceTest, AnswersEstimatesAndMarginalsAndNamesMissingKeys) {
  auto e = TwoRobots();
  QueryRequest q{.client = "c", .request_id = 3};
  q.keys = {{"r", KeyKind::kPose, 2},
            {"s", KeyKind::kPose, 3},
            {"r", KeyKind::kLandmark, 9},
            {"r", KeyKind::kPose, 77}};
  q.want_marginals = true;
  q.want_joint_marginal = true;
  const QueryAnswer a = AnswerQuery(*e, q, 1.0);
  ASSERT_EQ(a.results.size(), 4u);
  EXPECT_TRUE(a.results[0].found);
  EXPECT_TRUE(a.results[2].found);
  EXPECT_FALSE(a.results[3].found);
  EXPECT_EQ(a.results[3].key.index, 77u);
  const core::Point2& l9 = std::get<core::Point2>(a.results[2].value);
  EXPECT_NEAR(l9.x(), 1.0, 1e-9);
  EXPECT_NEAR(l9.y(), 0.0, 1e-9);
  // Pose 3 of s: prior + 3 identity odometry steps.
  EXPECT_TRUE(
      a.results[1].covariance.isApprox(Eigen::Matrix3d::Identity() * (1e-4 + 3 * 1e-2), 1e-9));
  EXPECT_EQ(a.results[2].covariance.rows(), 2);
  // A missing key makes the joint marginal impossible: partial, naming it.
  EXPECT_TRUE(a.partial);
  EXPECT_NE(a.error.find("r:x77"), std::string::npos) << a.error;
  EXPECT_EQ(a.joint.size(), 0);

  q.keys.pop_back();
  const QueryAnswer b = AnswerQuery(*e, q, 1.0);
  EXPECT_FALSE(b.partial) << b.error;
  ASSERT_EQ(b.joint.rows(), 3 + 3 + 2);
  // The robots are independent: zero cross-covariance between r and s.
  EXPECT_LT(b.joint.block(0, 3, 3, 3).norm(), 1e-12);
  EXPECT_TRUE(b.joint.block(3, 3, 3, 3).isApprox(b.results[1].covariance, 1e-12));
  EXPECT_TRUE(b.joint.block(6, 6, 2, 2).isApprox(b.results[2].covariance, 1e-12));
}

TEST(QueryServiceTest, ZeroBudgetLeavesMarginalsOutButNotEstimates) {
  auto e = TwoRobots();
  QueryRequest q{.client = "c", .request_id = 3};
  q.keys = {{"r", KeyKind::kPose, 1}};
  q.want_marginals = true;
  const QueryAnswer a = AnswerQuery(*e, q, 1e-12);
  ASSERT_EQ(a.results.size(), 1u);
  EXPECT_TRUE(a.results[0].found);
  EXPECT_TRUE(a.partial);
  EXPECT_EQ(a.results[0].covariance.size(), 0);
}

TEST(QueryServiceTest, MapsOfOneOrEveryRobotSortedWithMarginals) {
  auto e = TwoRobots();
  bool partial = true;
  std::vector<RobotMap> maps = CollectMaps(*e, "*", true, 1.0, &partial);
  EXPECT_FALSE(partial);
  ASSERT_EQ(maps.size(), 2u);
  EXPECT_EQ(maps[0].robot, "r");
  EXPECT_EQ(maps[1].robot, "s");
  ASSERT_EQ(maps[0].poses.size(), 4u);
  ASSERT_EQ(maps[0].landmarks.size(), 1u);
  EXPECT_EQ(maps[1].landmarks.size(), 0u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(maps[0].poses[i].index, i);
    EXPECT_TRUE(maps[0].poses[i].covariance.isApprox(
        Eigen::Matrix3d::Identity() * (1e-4 + static_cast<double>(i) * 1e-2), 1e-9));
  }
  EXPECT_FALSE(maps[0].is3d);
  maps = CollectMaps(*e, "s", false, 1.0, &partial);
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_EQ(maps[0].poses[0].covariance.size(), 0);
  EXPECT_TRUE(CollectMaps(*e, "nobody", true, 1.0, &partial).empty());
}

TEST(QueryServiceTest, LandmarksOfTheSharedMapAnswerAndMapAsRobotNone) {
  auto e = Estimator::Create({.chi2_interval_s = 0.0}, {}).value();
  std::vector<Inbound> batch = camera_test::Robot("a", 1);
  batch.push_back(camera_test::Camera("b"));
  batch.push_back(camera_test::PriorAt0("b", camera_test::BodyPose(1)));
  ASSERT_TRUE(e->Process(batch).status.ok());
  for (const auto& [robot, pose] : {std::pair{"a", 0}, std::pair{"b", 1}}) {
    const Inbound frame =
        camera_test::Frame(robot, 0, camera_test::BodyPose(pose), {{7, camera_test::kP1}}, false,
                           0.0, LandmarkNamespace::kMap);
    ASSERT_TRUE(e->Process({frame}).status.ok());
  }
  QueryRequest q{.client = "c", .request_id = 1};
  q.keys = {{"", KeyKind::kMapLandmark, 7}, {"", KeyKind::kMapLandmark, 8}};
  const QueryAnswer a = AnswerQuery(*e, q, 1.0);
  ASSERT_EQ(a.results.size(), 2u);
  ASSERT_TRUE(a.results[0].found);
  EXPECT_LT((std::get<core::Point3>(a.results[0].value) - camera_test::kP1).norm(), 1e-6);
  EXPECT_FALSE(a.results[1].found);

  bool partial = true;
  std::vector<RobotMap> maps = CollectMaps(*e, "*", false, 1.0, &partial);
  ASSERT_EQ(maps.size(), 3u);
  EXPECT_EQ(maps[2].robot, "");
  EXPECT_TRUE(maps[2].is3d);
  EXPECT_TRUE(maps[2].poses.empty());
  ASSERT_EQ(maps[2].landmarks.size(), 1u);
  EXPECT_EQ(maps[2].landmarks[0].index, 7u);
  EXPECT_TRUE(maps[0].landmarks.empty());  // not robot a's
  EXPECT_TRUE(CollectMaps(*e, "a", false, 1.0, &partial)[0].landmarks.empty());
}

}  // namespace
}  // namespace slamd::server
