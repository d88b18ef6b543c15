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
          "KeyCountDisagrees", g, [](M& m) { m.num_keys = 2; }, R::kSizeMismatch,
          "shard_summary_t.num_keys"),
      Make<M>(
          "TooManyKeys", g, [](M& m) { m.num_keys = 4097; }, R::kTooManyElements,
          "shard_summary_t.num_keys: 4097 not in [0, 4096]"),
      Make<M>(
          "RobotLandmarkKey", g, [](M& m) { m.keys[1].kind = 2; }, R::kBadKind,
          "shard_summary_t.keys[1].kind"),
      Make<M>(
          "MapLandmarkWithRobot", g, [](M& m) { m.keys[2].robot = "alpha"; }, R::kUnusedFieldSet,
          "shard_summary_t.keys[2].robot"),
      Make<M>(
          "PoseIndexNegative", g, [](M& m) { m.keys[0].index = -1; }, R::kIndexOutOfRange,
          "shard_summary_t.keys[0].index"),
      Make<M>(
          "RepeatedPose", g, [](M& m) { m.keys[1] = m.keys[0]; }, R::kDuplicate,
          "shard_summary_t.keys[1]"),
      Make<M>(
          "ValuesFor3d", g, [](M& m) { m.dimension = 3; }, R::kSizeMismatch,
          "shard_summary_t.num_values"),
      Make<M>(
          "ValueNaN", g, [](M& m) { m.values[7] = std::numeric_limits<double>::quiet_NaN(); },
          R::kNotFinite, "shard_summary_t.values[7]"),
      Make<M>(
          "MoreRowsThanColumns", g,
          [](M& m) {
            m.rows = 9;
            m.b.resize(9);
          },
          R::kSizeMismatch, "shard_summary_t.rows: 9 not in [1, 8]"),
      Make<M>(
          "RowsWithoutKeys", g,
          [](M& m) {
            m.keys.clear();
            m.num_keys = 0;
            m.values.clear();
            m.num_values = 0;
          },
          R::kSizeMismatch, "shard_summary_t.rows: 5 not in [0, 0]"),
      Make<M>(
          "LandmarkListNotAscending", g, [](M& m) { m.map_landmarks[2] = 7; }, R::kDuplicate,
          "shard_summary_t.map_landmarks[2]: not above"),
      Make<M>(
          "LandmarkListCountDisagrees", g, [](M& m) { m.num_map_landmarks = 4; }, R::kSizeMismatch,
          "shard_summary_t.num_map_landmarks"),
      Make<M>(
          "ACountDisagrees", g,
          [](M& m) {
            m.a.pop_back();
            m.num_a = 39;
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
  ASSERT_EQ(v.value().keys.size(), 3u);
  EXPECT_EQ(v.value().keys[1].robot, "bravo");
  EXPECT_EQ(v.value().keys[2], (WireKey{"", KeyKind::kMapLandmark, 7}));
  EXPECT_EQ(v.value().A.rows(), 5);
  EXPECT_EQ(v.value().A.cols(), 8);
  EXPECT_EQ(v.value().A(1, 4), m.a[1 * 8 + 4]);  // row-major on the wire
  EXPECT_EQ(std::get<core::Pose2>(v.value().x0[1]).x(), -1.0);
  EXPECT_EQ(std::get<core::Point2>(v.value().x0[2]).y(), 5.0);
  EXPECT_EQ(v.value().map_landmarks, (std::vector<std::uint64_t>{2, 7, 9}));
  slamd::shard_summary_t back;
  ToLcm(v.value(), &back);
  EXPECT_EQ(back.a, m.a);
  EXPECT_EQ(back.b, m.b);
  EXPECT_EQ(back.values, m.values);
  EXPECT_EQ(back.num_keys, 3);
  EXPECT_EQ(back.keys[2].kind, slamd::key_t::KIND_MAP_LANDMARK);
  EXPECT_EQ(back.map_landmarks, m.map_landmarks);
  EXPECT_EQ(ShardSummarySpec::Shard(back), "west");
  EXPECT_EQ(ShardSummarySpec::Robot(back), "east");
}

TEST(ShardSummaryMessage, OneWithoutKeysCarriesTheLandmarkList) {
  slamd::shard_summary_t m = ShardSummary();
  m.keys.clear();
  m.num_keys = 0;
  m.values.clear();
  m.num_values = 0;
  m.rows = 0;
  m.b.clear();
  m.a.clear();
  m.num_a = 0;
  const Checked<ShardSummaryMessage> v = Convert(m);
  ASSERT_TRUE(v.ok()) << v.verdict().message;
  EXPECT_TRUE(v.value().keys.empty());
  EXPECT_EQ(v.value().map_landmarks.size(), 3u);
}

}  // namespace
}  // namespace slamd::server
