#include "server/config/config_loader.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/testing/datasets.h"

namespace slamd::server {
namespace {

TEST(ConfigLoaderTest, EmptyTextGivesDefaults) {
  const core::Result<ServerParams> p = ParseConfigText("");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p.value().lcm_url, ServerParams{}.lcm_url);
  EXPECT_EQ(p.value().queue.depth, ServerParams{}.queue.depth);
}

TEST(ConfigLoaderTest, DefaultConfigTextParsesToDefaults) {
  const core::Result<ServerParams> p = ParseConfigText(DefaultConfigText());
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  const ServerParams d;
  const ServerParams& v = p.value();
  EXPECT_EQ(v.lcm_url, d.lcm_url);
  EXPECT_EQ(v.channel_prefix, d.channel_prefix);
  EXPECT_EQ(v.log_level, d.log_level);
  EXPECT_EQ(v.queue.depth, d.queue.depth);
  EXPECT_EQ(v.queue.block_timeout_s, d.queue.block_timeout_s);
  EXPECT_EQ(v.queue.coalesce_s, d.queue.coalesce_s);
  EXPECT_EQ(v.queue.max_per_update, d.queue.max_per_update);
  EXPECT_EQ(v.publish.status_rate_hz, d.publish.status_rate_hz);
  EXPECT_EQ(v.refine.enabled, d.refine.enabled);
  EXPECT_EQ(v.refine.budget_s, d.refine.budget_s);
  EXPECT_EQ(v.isam2.relinearization.skip, d.isam2.relinearization.skip);
  EXPECT_EQ(v.isam2.relinearization.rotation_threshold, d.isam2.relinearization.rotation_threshold);
  EXPECT_EQ(v.isam2.wildfire_threshold, d.isam2.wildfire_threshold);
  EXPECT_EQ(v.isam2.relinearization.error_threshold, d.isam2.relinearization.error_threshold);
  EXPECT_EQ(v.publish.latency_window, d.publish.latency_window);
  EXPECT_EQ(v.estimator.new_robot_anchor, d.estimator.new_robot_anchor);
  EXPECT_EQ(v.estimator.anchor_sigma, d.estimator.anchor_sigma);
  EXPECT_EQ(v.estimator.max_held_messages, d.estimator.max_held_messages);
  EXPECT_NE(DefaultConfigText().find("# "), std::string::npos);  // commented
}

TEST(ConfigLoaderTest, SetFieldsOverrideDefaults) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
lcm_url: "memq://"
channel_prefix: "TEST_"
queue { depth: 7 block_timeout_s: 0.5 coalesce_s: 0.002 max_per_update: 5 }
refine { enabled: false }
isam2 { relinearization { skip: 1 rotation_threshold: 0.01 error_threshold: 0 }
        wildfire_threshold: 0 threads: 1 refine_max_variables: 17 trust_region: true
        max_landmarks_last: 3 }
estimator { new_robot_anchor: ANCHOR_AT_ORIGIN max_hold_updates: 3 background_relinearization_above: 40
            rebuild_catch_up_rounds: 0 }
publish { latency_window: 64 }
)");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  const ServerParams& v = p.value();
  EXPECT_EQ(v.lcm_url, "memq://");
  EXPECT_EQ(v.channel_prefix, "TEST_");
  EXPECT_EQ(v.queue.depth, 7);
  EXPECT_EQ(v.queue.block_timeout_s, 0.5);
  EXPECT_EQ(v.queue.coalesce_s, 0.002);
  EXPECT_EQ(v.queue.max_per_update, 5);
  EXPECT_FALSE(v.refine.enabled);
  EXPECT_EQ(v.refine.budget_s, ServerParams{}.refine.budget_s);
  EXPECT_EQ(v.isam2.relinearization.skip, 1);
  EXPECT_EQ(v.isam2.relinearization.rotation_threshold, 0.01);
  EXPECT_EQ(v.isam2.relinearization.error_threshold, 0.0);
  EXPECT_EQ(v.publish.latency_window, 64);
  EXPECT_EQ(v.isam2.wildfire_threshold, 0.0);
  EXPECT_EQ(v.isam2.threads, 1);
  EXPECT_EQ(v.isam2.refine_max_variables, 17);
  EXPECT_TRUE(v.isam2.trust_region.enabled);
  EXPECT_FALSE(ServerParams{}.isam2.trust_region.enabled);
  EXPECT_EQ(v.isam2.max_landmarks_last, 3);
  EXPECT_EQ(v.estimator.new_robot_anchor, AnchorPolicy::kAnchorAtOrigin);
  EXPECT_EQ(v.estimator.max_hold_updates, 3);
  EXPECT_EQ(v.estimator.background_relinearization_above, 40);
  EXPECT_EQ(v.estimator.rebuild_catch_up_rounds, 0);
}

TEST(ConfigLoaderTest, UnknownFieldNamesLineAndField) {
  const core::Result<ServerParams> p =
      ParseConfigText("lcm_url: \"memq://\"\nqueue {\n  deph: 3\n}\n", "x.textproto");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), core::StatusCode::kInvalidArgument);
  EXPECT_NE(p.status().message().find("x.textproto:3:"), std::string::npos) << p.status().message();
  EXPECT_NE(p.status().message().find("deph"), std::string::npos) << p.status().message();
}

TEST(ConfigLoaderTest, OutOfRangeFieldNamesLineAndField) {
  const core::Result<ServerParams> p = ParseConfigText(
      "queue {\n  depth: 5\n}\nisam2 {\n  relinearization {\n    skip: 0\n  }\n}\n", "c");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().message(), "c:6:5: isam2.relinearization.skip = 0; violates >= 1");
  const core::Result<ServerParams> q = ParseConfigText("\n\nqueue { depth: 0 }\n", "c");
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.status().message(), "c:3:9: queue.depth = 0; violates >= 1");
  const core::Result<ServerParams> r = ParseConfigText("log_level: \"loud\"", "c");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("c:1:1: log_level"), std::string::npos)
      << r.status().message();
}

TEST(ConfigLoaderTest, PerTypeRelinearizationThresholds) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
isam2 { relinearization {
  calibration_threshold: 2 other_threshold: 0.3
  per_type { type: "Point3" kind: TRANSLATION threshold: 0.01 }
  per_type { type: "Cal3DS2" kind: CALIBRATION threshold: 0.5 }
} })");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  const core::Isam2Params::Relinearization& r = p->isam2.relinearization;
  EXPECT_EQ(r.calibration_threshold, 2.0);
  EXPECT_EQ(r.other_threshold, 0.3);
  ASSERT_EQ(r.per_type.size(), 2u);
  EXPECT_EQ(r.ThresholdOf(core::kVariableType<core::Point3>, core::EntryKind::kTranslation), 0.01);
  EXPECT_EQ(r.ThresholdOf(core::kVariableType<core::Pose3>, core::EntryKind::kTranslation), 0.1);
  EXPECT_EQ(r.ThresholdOf(core::kVariableType<core::Cal3DS2>, core::EntryKind::kCalibration), 0.5);
  // An unknown type is named, with its line.
  const core::Result<ServerParams> q = ParseConfigText(
      "isam2 {\n  relinearization {\n    per_type { type: \"Point4\" }\n  }\n}\n", "c");
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.status().message().find("unknown variable type 'Point4'"), std::string::npos)
      << q.status().message();
}

// The lifelong settings: the pose window, one robot's own window (unset fields from the
// default one), journal segments.
TEST(ConfigLoaderTest, LifelongWindowAndJournalSegments) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
estimator {
  window {
    keep_poses: 300 keyframe_spacing_m: 2.5 every_updates: 20 sparse_summaries: false
    summary_parents: 1 keep_aliases: 500
  }
  robot_window { robot: "car" keep_poses: 1000 }
}
journal { segment_bytes: 1048576 delete_covered_segments: false snapshot_every_bytes: 8388608 })");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p->estimator.window.keep_poses, 300);
  EXPECT_EQ(p->estimator.window.keyframe_spacing_m, 2.5);
  EXPECT_EQ(p->estimator.window.every_updates, 20);
  EXPECT_FALSE(p->estimator.window.sparse_summaries);
  EXPECT_EQ(p->estimator.window.summary_parents, 1);
  EXPECT_EQ(p->estimator.window.keep_aliases, 500);
  EXPECT_EQ(p->estimator.WindowOf("car").keep_aliases, 500);
  EXPECT_TRUE(EstimatorParams{}.window.sparse_summaries);
  EXPECT_EQ(EstimatorParams{}.window.summary_parents, 2);
  const core::Result<ServerParams> three =
      ParseConfigText("estimator {\n  window { summary_parents: 3 }\n}\n", "c");
  ASSERT_FALSE(three.ok());
  EXPECT_EQ(three.status().message(),
            "c:2:12: estimator.window.summary_parents = 3; violates <= 2");
  EXPECT_EQ(p->estimator.WindowOf("car").keep_poses, 1000);
  EXPECT_EQ(p->estimator.WindowOf("car").keyframe_spacing_m, 2.5);
  EXPECT_EQ(p->estimator.WindowOf("bike").keep_poses, 300);
  EXPECT_EQ(p->journal.segment_bytes, 1048576);
  EXPECT_FALSE(p->journal.delete_covered_segments);
  EXPECT_EQ(p->journal.snapshot_every_bytes, 8388608);
  for (const auto& [text, error] : std::vector<std::pair<std::string, std::string>>{
           {"estimator { window { keep_aliases: -1 } }",
            "estimator.window.keep_aliases = -1; violates >= 0"},
           {"journal { snapshot_every_bytes: -1 }",
            "journal.snapshot_every_bytes = -1; violates >= 0"},
           {"journal { segment_bytes: 100 }", "journal.segment_bytes = 100; violates >= 4096"}}) {
    const core::Result<ServerParams> q = ParseConfigText(text, "c");
    ASSERT_FALSE(q.ok()) << text;
    EXPECT_NE(q.status().message().find(error), std::string::npos) << q.status().message();
  }
}

// The reduced pose graph: the default one and a robot's own (unset fields from the default).
TEST(ConfigLoaderTest, ReducedPoseGraph) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
estimator {
  reduced { distance_m: 1.5 angle_deg: 20 keep_aliases: 50 link_mapped_landmarks: false }
  robot_reduced { robot: "car" reduced { distance_m: 4 link_mapped_landmarks: true } }
})");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p->estimator.ReducedOf("bike").distance_m, 1.5);
  EXPECT_EQ(p->estimator.ReducedOf("bike").angle_deg, 20.0);
  EXPECT_EQ(p->estimator.ReducedOf("bike").keep_aliases, 50);
  EXPECT_FALSE(p->estimator.ReducedOf("bike").link_mapped_landmarks);
  EXPECT_TRUE(p->estimator.ReducedOf("car").link_mapped_landmarks);
  EXPECT_EQ(p->estimator.ReducedOf("car").distance_m, 4.0);
  EXPECT_EQ(p->estimator.ReducedOf("car").angle_deg, 20.0);
  const core::Result<ServerParams> q =
      ParseConfigText("estimator { reduced { distance_m: 1 keep_aliases: 0 } }", "c");
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.status().message().find("estimator.reduced.keep_aliases = 0; violates >= 1"),
            std::string::npos)
      << q.status().message();
}

TEST(ConfigLoaderTest, Shards) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
shards {
  self: "east"
  shard { name: "west" robots: "r0" robots: "r1" }
  shard { name: "east" robots: "r2" }
  servers: "nats://a:4222" subject: "fleet.shards" summary_every_ms: 250
})");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  const ShardMap& m = p->estimator.shards;
  EXPECT_EQ(m.self, "east");
  ASSERT_EQ(m.shards.size(), 2u);
  EXPECT_EQ(m.shards[0].robots, (std::vector<std::string>{"r0", "r1"}));
  EXPECT_TRUE(m.Owns("r2"));
  EXPECT_FALSE(m.Owns("r1"));
  EXPECT_FALSE(m.Owns("r9"));  // unlisted: the first shard's
  EXPECT_EQ(m.Neighbours(), std::vector<std::string>{"west"});
  EXPECT_EQ(p->shards.servers, "nats://a:4222");
  EXPECT_EQ(p->shards.subject, "fleet.shards");
  EXPECT_EQ(p->shards.summary_every_ms, 250);
  EXPECT_FALSE(ServerParams{}.estimator.shards.sharded());  // off by default
  const core::Result<ServerParams> q =
      ParseConfigText(R"(shards { self: "x" shard { name: "y" } })", "c");
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.status().message().find("shards.self = 'x': not one of shards.shard"),
            std::string::npos)
      << q.status().message();
}

TEST(ConfigLoaderTest, Replication) {
  const core::Result<ServerParams> p = ParseConfigText(R"(
replication {
  servers: "nats://a:4222,nats://b:4222" stream: "S1" subject: "s.j" replicas: 5
  ack_timeout_ms: 250 lease_ttl_ms: 2000 lease_bucket: "L" standby_keep_s: 12.5
  keep_snapshots: 3
})");
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p->replication.servers, "nats://a:4222,nats://b:4222");
  EXPECT_EQ(p->replication.stream, "S1");
  EXPECT_EQ(p->replication.subject, "s.j");
  EXPECT_EQ(p->replication.replicas, 5);
  EXPECT_EQ(p->replication.ack_timeout_ms, 250);
  EXPECT_EQ(p->replication.lease_ttl_ms, 2000);
  EXPECT_EQ(p->replication.lease_bucket, "L");
  EXPECT_EQ(p->replication.standby_keep_s, 12.5);
  EXPECT_EQ(p->replication.keep_snapshots, 3);
  EXPECT_TRUE(ServerParams{}.replication.servers.empty());  // off by default
  for (const auto& [text, error] : std::vector<std::pair<std::string, std::string>>{
           {"replication { replicas: 0 }", "replication.replicas = 0; violates >= 1"},
           {"replication { lease_ttl_ms: 50 }", "replication.lease_ttl_ms = 50; violates >= 100"},
           {"replication { standby_keep_s: 0 }", "replication.standby_keep_s = 0"},
           {"replication { keep_snapshots: -1 }",
            "replication.keep_snapshots = -1; violates >= 0"}}) {
    const core::Result<ServerParams> q = ParseConfigText(text, "c");
    ASSERT_FALSE(q.ok()) << text;
    EXPECT_NE(q.status().message().find(error), std::string::npos) << q.status().message();
  }
}

TEST(ConfigLoaderTest, ValueOutOfTypeRangeAndBadEnumAreParseErrors) {
  const core::Result<ServerParams> p = ParseConfigText("queue { depth: 99999999999 }", "c");
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.status().message().find("c:1:"), std::string::npos) << p.status().message();
  const core::Result<ServerParams> q = ParseConfigText("estimator { new_robot_anchor: NOWHERE }");
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.status().message().find("NOWHERE"), std::string::npos) << q.status().message();
}

TEST(ConfigLoaderTest, LoadsFileAndReportsMissingFile) {
  const std::string path =
      testing::WriteTempFile("slamd_config_test.textproto", "channel_prefix: \"F_\"\n");
  const core::Result<ServerParams> p = LoadConfigFile(path);
  ASSERT_TRUE(p.ok()) << p.status().ToString();
  EXPECT_EQ(p.value().channel_prefix, "F_");
  const core::Result<ServerParams> missing = LoadConfigFile("/nonexistent/slamd.textproto");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), core::StatusCode::kNotFound);
}

}  // namespace
}  // namespace slamd::server

namespace slamd::server {
namespace {

// config/slamd.textproto is what --print-default-config prints; it must stay in step.
TEST(ConfigLoaderTest, ShippedDefaultConfigMatchesDefaultConfigText) {
  const std::string path = testing::TestDataPath("../../config/slamd.textproto");
  std::ifstream in(path);
  ASSERT_TRUE(in) << path;
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), DefaultConfigText()) << "regenerate: slamd --print-default-config > "
                                             << "config/slamd.textproto";
  EXPECT_TRUE(LoadConfigFile(path).ok());
}

}  // namespace
}  // namespace slamd::server
