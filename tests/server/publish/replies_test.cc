#include "server/publish/replies.h"

#include <gtest/gtest.h>

#include <vector>

namespace slamd::server {
namespace {

RobotMap Map3d(int poses, int landmarks, bool covariances) {
  RobotMap map{.robot = "r", .is3d = true};
  for (int i = 0; i < poses; ++i) {
    map.poses.push_back(
        {.index = static_cast<std::uint64_t>(i),
         .value = core::Pose3(core::Rot3(), core::Point3(i, 0, 0)),
         .covariance = covariances ? Eigen::MatrixXd::Identity(6, 6) * i : Eigen::MatrixXd()});
  }
  for (int i = 0; i < landmarks; ++i) {
    map.landmarks.push_back({.index = static_cast<std::uint64_t>(100 + i),
                             .value = core::Point3(0, i, 0),
                             .covariance = Eigen::MatrixXd()});
  }
  return map;
}

TEST(RepliesTest, MapPagesStayUnderTheBudgetAndKeepEveryEntryInOrder) {
  const RobotMap map = Map3d(1000, 300, true);
  const std::vector<slamd::map_t> pages = MapPages(map, 42, 7, 123);
  ASSERT_GT(pages.size(), 1u);
  std::vector<std::int64_t> poses, landmarks;
  for (size_t i = 0; i < pages.size(); ++i) {
    const slamd::map_t& p = pages[i];
    EXPECT_LE(p.getEncodedSize(), kMaxMapPageBytes) << "page " << i;
    EXPECT_EQ(p.page_index, static_cast<int>(i));
    EXPECT_EQ(p.page_count, static_cast<int>(pages.size()));
    EXPECT_EQ(p.update_sequence, 42);
    EXPECT_EQ(p.request_id, 7);
    EXPECT_EQ(p.dimension, slamd::map_t::DIMENSION_3D);
    EXPECT_EQ(p.num_poses, static_cast<int>(p.poses.size()));
    for (const auto& e : p.poses) {
      poses.push_back(e.index);
      ASSERT_EQ(e.num_values, 7);
      EXPECT_EQ(e.values[0], static_cast<double>(e.index));
      ASSERT_EQ(e.num_covariance, 36);
      EXPECT_EQ(e.covariance[7], static_cast<double>(e.index));
    }
    for (const auto& e : p.landmarks) landmarks.push_back(e.index);
    // Not much room wasted: every page but the last is at least 95% full.
    if (i + 1 < pages.size()) {
      EXPECT_GT(p.getEncodedSize(), kMaxMapPageBytes * 95 / 100);
    }
  }
  ASSERT_EQ(poses.size(), 1000u);
  ASSERT_EQ(landmarks.size(), 300u);
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(poses[i], i);
  for (int i = 0; i < 300; ++i) EXPECT_EQ(landmarks[i], 100 + i);
}

TEST(RepliesTest, EmptyMapIsOnePage) {
  const std::vector<slamd::map_t> pages = MapPages(Map3d(0, 0, false), 1, 0, 5);
  ASSERT_EQ(pages.size(), 1u);
  EXPECT_EQ(pages[0].page_count, 1);
  EXPECT_EQ(pages[0].num_poses, 0);
}

TEST(RepliesTest, QueryReplyLaysOutResultsAndJoint) {
  QueryRequest q{.client = "c", .request_id = 11};
  QueryAnswer a;
  VariableAnswer found;
  found.key = {"r", KeyKind::kPose, 3};
  found.found = true;
  found.value = core::Pose2(1, 2, 0.5);
  found.covariance = Eigen::Matrix3d::Identity() * 2;
  a.results.push_back(found);
  VariableAnswer missing;
  missing.key = {"r", KeyKind::kLandmark, 4};
  a.results.push_back(missing);
  a.joint = Eigen::Matrix2d{{1, 2}, {3, 4}};
  slamd::query_reply_t out;
  FillQueryReply(q, a, 9, 2, 77, &out);
  EXPECT_EQ(out.status, slamd::query_reply_t::STATUS_OK);
  EXPECT_EQ(out.request_id, 11);
  EXPECT_EQ(out.update_sequence, 9);
  EXPECT_EQ(out.map_pages, 2);
  ASSERT_EQ(out.num_results, 2);
  EXPECT_EQ(out.results[0].values, (std::vector<double>{1, 2, 0.5}));
  EXPECT_EQ(out.results[0].num_covariance, 9);
  EXPECT_EQ(out.results[1].num_values, 0);
  EXPECT_EQ(out.results[1].key.kind, 2);
  EXPECT_EQ(out.joint_dimension, 2);
  EXPECT_EQ(out.joint_covariance, (std::vector<double>{1, 2, 3, 4}));  // row-major
  a.partial = true;
  a.error = "why";
  FillQueryReply(q, a, 9, 0, 77, &out);
  EXPECT_EQ(out.status, slamd::query_reply_t::STATUS_PARTIAL);
  EXPECT_EQ(out.error, "why");
}

TEST(FillReject, CopiesEveryField) {
  Verdict v{.reason = RejectReason::kNotFinite,
            .message = "odometry_t.values[0]: not finite (nan)"};
  slamd::reject_t r;
  FillReject(v, "SLAMD_ODOMETRY", "odometry_t", "alpha", 123, 456, &r);
  EXPECT_EQ(r.utime, 456);
  EXPECT_EQ(r.channel, "SLAMD_ODOMETRY");
  EXPECT_EQ(r.message_type, "odometry_t");
  EXPECT_EQ(r.robot, "alpha");
  EXPECT_EQ(r.message_utime, 123);
  EXPECT_EQ(r.reason, slamd::reject_t::REASON_NOT_FINITE);
  EXPECT_EQ(r.detail, v.message);
}

}  // namespace
}  // namespace slamd::server
