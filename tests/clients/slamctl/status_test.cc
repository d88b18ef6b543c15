// `slamctl status`: argument errors exit 2; no status_t within --timeout exits 1 with a hint.
// (The live answer is checked by tests/integration/server_replay_netns_test.cc.)
#include <gtest/gtest.h>

#include "clients/slamctl/client_common.h"
#include "server/ingest/reject_reason.h"
#include "tests/clients/slamctl/slamctl_runner.h"

namespace slamd::clients {
namespace {

using testing::RunSlamctl;

TEST(StatusCommandTest, ArgumentErrorsAndTimeout) {
  testing::SlamctlRun run = RunSlamctl("status --timeout 0");
  EXPECT_EQ(run.exit_code, 2) << run.out;
  run = RunSlamctl("status --channel-prefix 'no spaces' --lcm-url memq://");
  EXPECT_EQ(run.exit_code, 2) << run.out;
  EXPECT_NE(run.out.find("only [A-Za-z0-9_]"), std::string::npos) << run.out;
  run = RunSlamctl("status --lcm-url memq:// --timeout 0.2");
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("no status_t on SLAMD_STATUS within"), std::string::npos) << run.out;
}

TEST(StatusCommandTest, FormatsEveryField) {
  slamd::status_t s{};
  s.update_sequence = 42;
  s.rebuilds = 7;
  s.queue_capacity = 1000;
  s.queue_peak = 12;
  s.num_robots = 2;
  s.messages_received = 1000;
  s.chi2 = 45.5;
  s.residual_dimension = 100;
  s.settled = true;
  s.num_rejects_by_reason = server::kNumRejectReasonCodes;
  s.rejects_by_reason.assign(server::kNumRejectReasonCodes, 0);
  s.rejects_by_reason[35] = 3;
  const std::string text = FormatStatus(s);
  EXPECT_NE(text.find("update 42"), std::string::npos) << text;
  EXPECT_NE(text.find("settled"), std::string::npos) << text;
  EXPECT_NE(text.find("rejected duplicate: 3"), std::string::npos) << text;
  EXPECT_NE(text.find("chi2 45.5"), std::string::npos) << text;
  EXPECT_NE(text.find("rebuilds 7"), std::string::npos) << text;
  EXPECT_NE(text.find("queue 0 / 1000 (peak 12)"), std::string::npos) << text;
  const std::string json = StatusJson(s).str();
  EXPECT_NE(json.find("\"rejects_by_reason\": {\"duplicate\": 3}"), std::string::npos) << json;
  EXPECT_NE(json.find("\"settled\": true"), std::string::npos) << json;
  EXPECT_NE(json.find("\"update_sequence\": 42"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rebuilds\": 7"), std::string::npos) << json;
  EXPECT_NE(json.find("\"queue_peak\": 12"), std::string::npos) << json;
}

}  // namespace
}  // namespace slamd::clients
