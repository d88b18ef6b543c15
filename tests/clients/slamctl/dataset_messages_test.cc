// dataset_messages: each factor kind becomes the right message with the measured value and the
// covariance Ω⁻¹ (checked against Eigen's dense inverse of the file's information), Pose3 too,
// the prior first; and M3500's first 100 steps, converted back with server Convert(), give the
// dataset's factors.
#include "clients/slamctl/dataset_messages.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/dataset_stream.h"
#include "server/messages/inbound.h"
#include "tests/testing/datasets.h"

namespace slamd::clients {
namespace {

using core::Pose2;
using core::Pose3;

core::Dataset Read(const std::string& name, const std::string& text) {
  core::Result<core::Dataset> d = core::ReadDataset(testing::WriteTempFile(name, text));
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  return std::move(d).value();
}

Eigen::MatrixXd RowMajor(const std::vector<double>& v, int n) {
  Eigen::MatrixXd m(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) m(r, c) = v[static_cast<size_t>(r * n + c)];
  return m;
}

Eigen::MatrixXd Upper(const std::vector<double>& u, int n) {
  Eigen::MatrixXd m(n, n);
  int k = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i; j < n; ++j) m(i, j) = m(j, i) = u[static_cast<size_t>(k++)];
  return m;
}

constexpr const char* kSmall2d =
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1 0 0.1\n"
    "VERTEX_SE2 2 2 0.1 0.2\n"
    "VERTEX_SE2 3 3 0.3 0.3\n"
    "EDGE_SE2 0 1 1.0 0.01 0.1 100 2 1 90 3 400\n"
    "EDGE_SE2_XY 1 7 0.5 2.0 30 4 20\n"
    "EDGE_SE2 1 2 1.1 0.02 0.12 110 0 0 100 0 500\n"
    "EDGE_SE2 0 2 2.0 0.1 0.2 50 1 0 60 0 200\n"
    "EDGE_SE2 3 2 -1.0 0.05 -0.1 120 5 2 80 1 300\n";  // reversed odometry of step 3

TEST(DatasetMessagesTest, Pose2FactorsBecomeTheRightMessagesInStepOrder) {
  const core::Dataset d = Read("small.g2o", kSmall2d);
  auto steps = MakeDatasetMessages(d, {.robot = "bot", .anchor_sigma = 0.01});
  ASSERT_TRUE(steps.ok()) << steps.status().ToString();
  ASSERT_EQ(steps->size(), 4u);
  EXPECT_EQ(CountMessages(*steps), 6u);

  // Step 0: the anchoring prior at the first pose's initial value, sigma 0.01.
  ASSERT_EQ((*steps)[0].messages.size(), 1u);
  EXPECT_TRUE((*steps)[0].introduces_pose);
  const auto& prior = std::get<slamd::prior_t>((*steps)[0].messages[0]);
  EXPECT_EQ(prior.robot, "bot");
  EXPECT_EQ(prior.kind, slamd::prior_t::KIND_POSE_2D);
  EXPECT_EQ(prior.values, (std::vector<double>{0, 0, 0}));
  EXPECT_TRUE(RowMajor(prior.covariance, 3).isApprox(1e-4 * Eigen::MatrixXd::Identity(3, 3)));

  // Step 1: odometry 0 -> 1 with covariance = information⁻¹, then the landmark observation.
  ASSERT_EQ((*steps)[1].messages.size(), 2u);
  const auto& odo = std::get<slamd::odometry_t>((*steps)[1].messages[0]);
  EXPECT_EQ(odo.from_index, 0);
  EXPECT_EQ(odo.to_index, 1);
  EXPECT_EQ(odo.dimension, slamd::odometry_t::DIMENSION_2D);
  EXPECT_NEAR(odo.values[0], 1.0, 1e-15);
  EXPECT_NEAR(odo.values[1], 0.01, 1e-15);
  EXPECT_NEAR(odo.values[2], 0.1, 1e-15);
  const Eigen::MatrixXd info = Upper({100, 2, 1, 90, 3, 400}, 3);
  EXPECT_TRUE(RowMajor(odo.covariance, 3).isApprox(info.inverse(), 1e-12));
  const auto& lm = std::get<slamd::landmark_observation_t>((*steps)[1].messages[1]);
  EXPECT_EQ(lm.kind, slamd::landmark_observation_t::KIND_RELATIVE_POINT_2D);
  EXPECT_EQ(lm.pose_index, 1);
  EXPECT_EQ(lm.landmark_id, 7);
  EXPECT_EQ(lm.values, (std::vector<double>{0.5, 2.0}));
  EXPECT_TRUE(RowMajor(lm.covariance, 2).isApprox(Upper({30, 4, 20}, 2).inverse(), 1e-12));

  // Step 2: odometry 1 -> 2, then the loop closure 0 -> 2 in its file direction.
  ASSERT_EQ((*steps)[2].messages.size(), 2u);
  EXPECT_EQ(std::get<slamd::odometry_t>((*steps)[2].messages[0]).from_index, 1);
  const auto& lc = std::get<slamd::loop_closure_t>((*steps)[2].messages[1]);
  EXPECT_EQ(lc.robot_a, "bot");
  EXPECT_EQ(lc.robot_b, "bot");
  EXPECT_EQ(lc.pose_a, 0);
  EXPECT_EQ(lc.pose_b, 2);
  EXPECT_EQ(lc.values, (std::vector<double>{2.0, 0.1, 0.2}));
  EXPECT_TRUE(
      RowMajor(lc.covariance, 3).isApprox(Upper({50, 1, 0, 60, 0, 200}, 3).inverse(), 1e-12));
  EXPECT_EQ(lc.robust_kernel, "");

  // Step 3: the edge 3 -> 2 is sent forwards, 2 -> 3: z⁻¹ with covariance H Σ Hᵀ.
  const auto& rev = std::get<slamd::odometry_t>((*steps)[3].messages[0]);
  EXPECT_EQ(rev.from_index, 2);
  EXPECT_EQ(rev.to_index, 3);
  core::Matrix3 H;
  const Pose2 inv = Pose2(-1.0, 0.05, -0.1).Inverse(&H);
  EXPECT_NEAR(rev.values[0], inv.x(), 1e-12);
  EXPECT_NEAR(rev.values[1], inv.y(), 1e-12);
  EXPECT_NEAR(rev.values[2], inv.theta(), 1e-12);
  const Eigen::MatrixXd sigma = Upper({120, 5, 2, 80, 1, 300}, 3).inverse();
  EXPECT_TRUE(RowMajor(rev.covariance, 3).isApprox(H * sigma * H.transpose(), 1e-9));
  // The reversed measurement predicts the same pose 3 from pose 2 (to first order exactly).
  const Pose2 x2(2, 0.1, 0.2);
  const Pose2 x3_file = x2 * Pose2(-1.0, 0.05, -0.1).Inverse();
  const Pose2 x3_msg = x2 * Pose2(rev.values[0], rev.values[1], rev.values[2]);
  EXPECT_NEAR(x3_file.x(), x3_msg.x(), 1e-12);
  EXPECT_NEAR(x3_file.theta(), x3_msg.theta(), 1e-12);

  // utime k * 1000 µs.
  EXPECT_EQ(rev.utime, 3000);
  EXPECT_EQ(ChannelOf((*steps)[2].messages[1], server::ChannelNames{"P_"}), "P_LOOP_CLOSURE");
}

TEST(DatasetMessagesTest, Pose3FactorsCarryQuaternionAndSixBySixCovariance) {
  // g2o 3D: quaternion (qx qy qz qw), information upper triangle of 6x6.
  std::ostringstream info;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) info << " " << (i == j ? 100.0 + 10 * i : 1.0);
  std::ostringstream file;
  file << "VERTEX_SE3:QUAT 0 1 2 3 0 0 0.3826834323650898 0.9238795325112867\n"
       << "VERTEX_SE3:QUAT 1 2 2 3 0 0 0 1\n"
       << "VERTEX_SE3:QUAT 2 3 2 3 0 0 0 1\n"
       << "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.0998334166468282 0.9950041652780258" << info.str() << "\n"
       << "EDGE_SE3:QUAT 0 2 2 0.1 0 0.1 0 0 0.9949874371066200" << info.str() << "\n"
       << "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1" << info.str() << "\n";
  const std::string text = file.str();
  const core::Dataset d = Read("small3d.g2o", text);
  ASSERT_TRUE(d.is_3d);
  auto steps = MakeDatasetMessages(d, {.robot = "r3"});
  ASSERT_TRUE(steps.ok()) << steps.status().ToString();
  const auto& prior = std::get<slamd::prior_t>((*steps)[0].messages[0]);
  EXPECT_EQ(prior.kind, slamd::prior_t::KIND_POSE_3D);
  ASSERT_EQ(prior.values.size(), 7u);
  EXPECT_NEAR(prior.values[0], 1, 1e-12);
  EXPECT_NEAR(prior.values[3], 0.9238795325112867, 1e-12);  // qw first on the wire
  EXPECT_NEAR(prior.values[6], 0.3826834323650898, 1e-12);  // qz
  EXPECT_TRUE(RowMajor(prior.covariance, 6).isApprox(1e-6 * Eigen::MatrixXd::Identity(6, 6)));
  const auto& odo = std::get<slamd::odometry_t>((*steps)[1].messages[0]);
  EXPECT_EQ(odo.dimension, slamd::odometry_t::DIMENSION_3D);
  EXPECT_NEAR(odo.values[3], 0.9950041652780258, 1e-12);
  EXPECT_NEAR(odo.values[6], 0.0998334166468282, 1e-12);  // qz
  std::vector<double> upper;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) upper.push_back(i == j ? 100.0 + 10 * i : 1.0);
  EXPECT_TRUE(RowMajor(odo.covariance, 6).isApprox(Upper(upper, 6).inverse(), 1e-12));
  // Step 2: odometry 1 -> 2 (the previous pose is preferred), then the closure 0 -> 2.
  ASSERT_EQ((*steps)[2].messages.size(), 2u);
  EXPECT_EQ(std::get<slamd::odometry_t>((*steps)[2].messages[0]).from_index, 1);
  const auto& lc = std::get<slamd::loop_closure_t>((*steps)[2].messages[1]);
  EXPECT_EQ(lc.dimension, slamd::loop_closure_t::DIMENSION_3D);
  EXPECT_EQ(lc.pose_a, 0);
  EXPECT_NEAR(lc.values[1], 0.1, 1e-12);
}

TEST(DatasetMessagesTest, BearingRangeBecomesALandmarkObservation) {
  core::Dataset d;
  d.poses = {core::MakeKey('x', 0), core::MakeKey('x', 1)};
  d.landmarks = {core::MakeKey('l', 4)};
  ASSERT_TRUE(d.initial.Insert(d.poses[0], Pose2()).ok());
  ASSERT_TRUE(d.initial.Insert(d.poses[1], Pose2(1, 0, 0)).ok());
  ASSERT_TRUE(d.initial.Insert(d.landmarks[0], core::Point2(2, 2)).ok());
  Eigen::MatrixXd cov(2, 2);
  cov << 0.01, 0.002, 0.002, 0.04;
  d.graph.Emplace<core::BetweenFactor<Pose2>>(d.poses[0], d.poses[1], Pose2(1, 0, 0),
                                              core::NoiseModel::Isotropic(3, 0.1).value());
  d.graph.Emplace<core::BearingRangeFactor>(d.poses[1], d.landmarks[0], 0.7, 2.3,
                                            core::NoiseModel::FromCovariance(cov).value());
  auto steps = MakeDatasetMessages(d, {});
  ASSERT_TRUE(steps.ok()) << steps.status().ToString();
  const auto& lm = std::get<slamd::landmark_observation_t>((*steps)[1].messages[1]);
  EXPECT_EQ(lm.kind, slamd::landmark_observation_t::KIND_BEARING_RANGE_2D);
  EXPECT_EQ(lm.landmark_id, 4);
  EXPECT_NEAR(lm.values[0], 0.7, 1e-15);
  EXPECT_NEAR(lm.values[1], 2.3, 1e-15);
  EXPECT_TRUE(RowMajor(lm.covariance, 2).isApprox(cov, 1e-12));
  EXPECT_EQ(lm.landmark_namespace, slamd::landmark_observation_t::NAMESPACE_ROBOT);
  // Datasets of several robots numbering one world's landmarks name the shared map's.
  auto shared = MakeDatasetMessages(d, {.shared_landmarks = true});
  ASSERT_TRUE(shared.ok());
  const auto& map = std::get<slamd::landmark_observation_t>((*shared)[1].messages[1]);
  EXPECT_EQ(map.landmark_namespace, slamd::landmark_observation_t::NAMESPACE_MAP);
  EXPECT_EQ(map.landmark_id, 4);
}

TEST(DatasetMessagesTest, OptionsAndUnsupportedFactors) {
  const core::Dataset d = Read("small.g2o", kSmall2d);
  auto no_prior = MakeDatasetMessages(d, {.anchor_sigma = 0.0});
  ASSERT_TRUE(no_prior.ok());
  EXPECT_TRUE((*no_prior)[0].messages.empty());
  EXPECT_FALSE((*no_prior)[0].introduces_pose);
  EXPECT_FALSE(MakeDatasetMessages(d, {.robot = "bad name"}).ok());
  EXPECT_FALSE(MakeDatasetMessages(d, {.robot = ""}).ok());
  EXPECT_FALSE(MakeDatasetMessages(d, {.anchor_sigma = -1}).ok());

  core::Dataset with_prior = Read("small.g2o", kSmall2d);
  with_prior.graph.Emplace<core::PriorFactor<Pose2>>(with_prior.poses[2], Pose2(),
                                                     core::NoiseModel::Unit(3));
  auto bad = MakeDatasetMessages(with_prior, {});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("PriorPose2"), std::string::npos) << bad.status().message();
}

// Every message of M3500's first 100 steps, decoded by the server's own Convert(), gives back the
// dataset's factor: same keys, same measurement, same information.
TEST(DatasetMessagesTest, M3500MessagesConvertBackToTheDatasetFactors) {
  const std::string path = testing::SharedDatasetPath("input_M3500_g2o.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  core::Result<core::Dataset> d = core::ReadDataset(path);
  ASSERT_TRUE(d.ok()) << d.status().ToString();
  auto steps = MakeDatasetMessages(*d, {.robot = "m3500"});
  ASSERT_TRUE(steps.ok()) << steps.status().ToString();
  const std::vector<core::DatasetStep> ref = core::MakeIncrementalSteps(*d);
  ASSERT_EQ(steps->size(), ref.size());
  int compared = 0;
  for (size_t k = 0; k < 100; ++k) {
    // Reference order: odometry first, then the other factors in graph order.
    std::vector<core::FactorPtr> want;
    if (ref[k].odometry) want.push_back(ref[k].odometry);
    for (const core::FactorPtr& f : ref[k].factors)
      if (f != ref[k].odometry) want.push_back(f);
    const std::vector<RobotMessage>& got = (*steps)[k].messages;
    const size_t offset = k == 0 ? 1 : 0;  // the prior
    ASSERT_EQ(got.size(), want.size() + offset) << "step " << k;
    for (size_t i = 0; i < want.size(); ++i) {
      const auto* between = dynamic_cast<const core::BetweenFactor<Pose2>*>(want[i].get());
      ASSERT_NE(between, nullptr);
      Pose2 measured;
      core::NoiseModel noise = core::NoiseModel::Unit(3);
      std::uint64_t a = 0, b = 0;
      if (const auto* odo = std::get_if<slamd::odometry_t>(&got[i + offset])) {
        auto m = server::Convert(*odo);
        ASSERT_TRUE(m.ok()) << m.verdict().message;
        measured = std::get<Pose2>(m.value().measured);
        noise = m.value().noise;
        a = m.value().from_index;
        b = m.value().to_index;
      } else {
        auto m = server::Convert(std::get<slamd::loop_closure_t>(got[i + offset]));
        ASSERT_TRUE(m.ok()) << m.verdict().message;
        measured = std::get<Pose2>(m.value().measured);
        noise = m.value().noise;
        a = m.value().pose_a;
        b = m.value().pose_b;
        EXPECT_EQ(m.value().robot_a, "m3500");
      }
      EXPECT_EQ(a, core::KeyIndex(between->keys()[0]));
      EXPECT_EQ(b, core::KeyIndex(between->keys()[1]));
      EXPECT_NEAR(measured.x(), between->measured().x(), 1e-12);
      EXPECT_NEAR(measured.y(), between->measured().y(), 1e-12);
      EXPECT_NEAR(measured.theta(), between->measured().theta(), 1e-12);
      EXPECT_TRUE(noise.Information().isApprox(between->noise_model().Information(), 1e-9));
      ++compared;
    }
  }
  EXPECT_GT(compared, 100);
}

}  // namespace
}  // namespace slamd::clients
