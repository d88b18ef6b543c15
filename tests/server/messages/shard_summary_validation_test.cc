// The stateless rejection cases of shard_summary_t (run by validation_test.cc's RejectionTest),
// acceptance of a good one, and its conversion to the estimator's value and back.
#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "server/messages/inbound.h"
#include "tests/server/ingest/test_messages.h"
#include "tests/server/messages/rejection_cases.h"

namespace slamd::server {
namespace {

using namespace testing;          // NOLINT: the example messages
using namespace rejection_cases;  // NOLINT: Case, Make, RejectionTest

std::vector<Case> ShardSummaryCases() {
  using M = slamd::shard_summary_t;
  const M g = ShardSummary();
  return {
      Make<M>(
          "BadTimestamp", g, [](M& m) { m.utime = -3; }, R::kBadTimestamp, "shard_summary_t.utime"),
      Make<M>(
          "FromShardEmpty", g, [](M& m) { m.from_shard = ""; }, R::kBadName,
          "shard_summary_t.from_shard: empty"),
      Make<M>(
          "ToShardBadChar", g, [](M& m) { m.to_shard = "we st"; }, R::kBadName,
          "shard_summary_t.to_shard: character 2"),
      Make<M>(
          "Dimension5", g, [](M& m) { m.dimension = 5; }, R::kBadKind,
          "shard_summary_t.dimension: 5"),
      Make<M>(
          "NoPoses", g,
          [](M& m) {
            m.poses.clear();
            m.num_poses = 0;
          },
          R::kTooManyElements, "shard_summary_t.num_poses: 0"),
      Make<M>(
          "PoseCountDisagrees", g, [](M& m) { m.num_poses = 3; }, R::kSizeMismatch,
          "shard_summary_t.num_poses"),
      Make<M>(
          "LandmarkKey", g, [](M& m) { m.poses[1].kind = 2; }, R::kBadKind,
          "shard_summary_t.poses[1].kind"),
      Make<M>(
          "PoseIndexNegative", g, [](M& m) { m.poses[0].index = -1; }, R::kIndexOutOfRange,
          "shard_summary_t.poses[0].index"),
      Make<M>(
          "RepeatedPose", g, [](M& m) { m.poses[1] = m.poses[0]; }, R::kDuplicate,
          "shard_summary_t.poses[1]"),
      Make<M>(
          "ValuesFor3d", g, [](M& m) { m.dimension = 3; }, R::kSizeMismatch,
          "shard_summary_t.num_values"),
      Make<M>(
          "ValueNaN", g, [](M& m) { m.values[2] = std::numeric_limits<double>::quiet_NaN(); },
          R::kNotFinite, "shard_summary_t.values[2]"),
      Make<M>(
          "MoreRowsThanColumns", g,
          [](M& m) {
            m.rows = 7;
            m.b.resize(7);
          },
          R::kSizeMismatch, "shard_summary_t.rows: 7 not in [1, 6]"),
      Make<M>(
          "ACountDisagrees", g,
          [](M& m) {
            m.a.pop_back();
            m.num_a = 23;
          },
          R::kSizeMismatch, "shard_summary_t.num_a"),
      Make<M>(
          "AInfinite", g, [](M& m) { m.a[5] = std::numeric_limits<double>::infinity(); },
          R::kNotFinite, "shard_summary_t.a[5]"),
      Make<M>(
          "BNaN", g, [](M& m) { m.b[3] = std::numeric_limits<double>::quiet_NaN(); }, R::kNotFinite,
          "shard_summary_t.b[3]"),
  };
}

INSTANTIATE_TEST_SUITE_P(ShardSummary, RejectionTest, ::testing::ValuesIn(ShardSummaryCases()),
                         CaseName);

TEST(ShardSummaryMessage, GoodOneConvertsAndRoundTrips) {
  const slamd::shard_summary_t m = ShardSummary();
  const Checked<ShardSummaryMessage> v = Convert(m);
  ASSERT_TRUE(v.ok()) << v.verdict().message;
  ASSERT_EQ(v.value().poses.size(), 2u);
  EXPECT_EQ(v.value().poses[1].first, "bravo");
  EXPECT_EQ(v.value().A.rows(), 4);
  EXPECT_EQ(v.value().A.cols(), 6);
  EXPECT_EQ(v.value().A(1, 4), m.a[1 * 6 + 4]);  // row-major on the wire
  EXPECT_EQ(std::get<core::Pose2>(v.value().x0[1]).x(), -1.0);
  slamd::shard_summary_t back;
  ToLcm(v.value(), &back);
  EXPECT_EQ(back.a, m.a);
  EXPECT_EQ(back.b, m.b);
  EXPECT_EQ(back.values, m.values);
  EXPECT_EQ(back.num_poses, 2);
  EXPECT_EQ(ShardSummarySpec::Shard(back), "west");
  EXPECT_EQ(ShardSummarySpec::Robot(back), "east");
}

}  // namespace
}  // namespace slamd::server
