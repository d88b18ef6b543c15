#include "server/config/server_params.h"

#include <gtest/gtest.h>

namespace slamd::server {
namespace {

TEST(ServerParamsTest, DefaultsValidate) { EXPECT_TRUE(ServerParams{}.Validate().ok()); }

TEST(ServerParamsTest, EachViolationNamesItsField) {
  struct Case {
    void (*mutate)(ServerParams*);
    const char* field;
  };
  const Case cases[] = {
      {[](ServerParams* p) { p->lcm_url = ""; }, "lcm_url"},
      {[](ServerParams* p) { p->channel_prefix = "A-B"; }, "channel_prefix"},
      {[](ServerParams* p) { p->channel_prefix = std::string(41, 'A'); }, "channel_prefix"},
      {[](ServerParams* p) { p->log_level = "verbose"; }, "log_level"},
      {[](ServerParams* p) { p->queue.depth = 0; }, "queue.depth"},
      {[](ServerParams* p) { p->queue.block_timeout_s = -1; }, "queue.block_timeout_s"},
      {[](ServerParams* p) { p->queue.coalesce_s = 0.5; }, "queue.coalesce_s"},
      {[](ServerParams* p) { p->queue.max_per_update = 0; }, "queue.max_per_update"},
      {[](ServerParams* p) { p->publish.status_rate_hz = -1; }, "publish.status_rate_hz"},
      {[](ServerParams* p) { p->publish.map_rate_hz = 1000; }, "publish.map_rate_hz"},
      {[](ServerParams* p) { p->publish.latency_window = 8; }, "publish.latency_window"},
      {[](ServerParams* p) { p->refine.budget_s = 0; }, "refine.budget_s"},
      {[](ServerParams* p) { p->isam2.relinearization.skip = 0; }, "isam2.relinearization.skip"},
      {[](ServerParams* p) { p->isam2.batch_every = -1; }, "isam2.batch_every"},
      {[](ServerParams* p) { p->isam2.threads = 0; }, "isam2.threads"},
      {[](ServerParams* p) { p->isam2.refine_max_variables = -1; }, "isam2.refine_max_variables"},
      {[](ServerParams* p) { p->estimator.anchor_sigma = 0; }, "estimator.anchor_sigma"},
      {[](ServerParams* p) { p->estimator.max_held_messages = -1; }, "estimator.max_held_messages"},
      {[](ServerParams* p) { p->estimator.max_hold_updates = 0; }, "estimator.max_hold_updates"},
      {[](ServerParams* p) { p->estimator.background_relinearization_above = -1; },
       "estimator.background_relinearization_above"},
      {[](ServerParams* p) { p->estimator.rebuild_catch_up_rounds = -1; },
       "estimator.rebuild_catch_up_rounds"},
      {[](ServerParams* p) { p->estimator.rebuild_catch_up_rounds = 65; },
       "estimator.rebuild_catch_up_rounds"},
      {[](ServerParams* p) { p->shards.summary_every_ms = 5; }, "shards.summary_every_ms"},
      {[](ServerParams* p) { p->shards.subject = "slamd.*"; }, "shards.subject"},
      {[](ServerParams* p) { p->shards.subject = "slamd..x"; }, "shards.subject"},
      {[](ServerParams* p) {
         p->estimator.shards = {.self = "", .shards = {{"a", {}}}};
       },
       "shards.self"},
      {[](ServerParams* p) {
         p->estimator.shards = {.self = "c", .shards = {{"a", {}}}};
       },
       "shards.self"},
      {[](ServerParams* p) {
         p->estimator.shards = {.self = "a", .shards = {{"a", {}}, {"a", {}}}};
       },
       "shards.shard.name"},
      {[](ServerParams* p) {
         p->estimator.shards = {.self = "a b", .shards = {{"a b", {}}}};
       },
       "shards.shard.name"},
      {[](ServerParams* p) {
         p->estimator.shards = {.self = "a", .shards = {{"a", {"r"}}, {"b", {"r"}}}};
       },
       "shards.shard.robots"},
  };
  for (const Case& c : cases) {
    ServerParams p;
    c.mutate(&p);
    const core::Status s = p.Validate();
    ASSERT_FALSE(s.ok()) << c.field;
    EXPECT_EQ(s.message().rfind(c.field, 0), 0u) << s.message();
  }
}

TEST(ServerParamsTest, LogLevels) {
  EXPECT_EQ(LogLevelNumber("trace"), 0);
  EXPECT_EQ(LogLevelNumber("off"), 6);
  EXPECT_EQ(LogLevelNumber("loud"), -1);
}

}  // namespace
}  // namespace slamd::server
