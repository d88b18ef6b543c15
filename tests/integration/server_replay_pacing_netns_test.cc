// `slamctl replay --rate` against the real slamd over UDP multicast (udpm://, ttl=0, inside a
// private network namespace: ctest label netns) sends each pose at its own time. Its wait for a
// send time used to end only when a message arrived (or after LCM's 100 ms timeout): the poses
// then went out in bursts whenever slamd's idle-time refinement published (every ~20 ms), slamd
// made one update of several poses per burst, and the server benchmark's 1 kHz latencies were
// several times too high.
#include <gtest/gtest.h>
#include <signal.h>

#include <regex>
#include <sstream>
#include <string>

#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"

namespace slamd::server {
namespace {

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

double JsonNumber(const std::string& json, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + key + "\": ([0-9.eE+-]+)"))) return -1;
  return std::stod(m[1].str());
}

TEST(ReplayPacingNetnsTest, RateSendsEveryPoseAtItsTime) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  constexpr int kPoses = 300;
  constexpr double kRate = 1000.0;
  std::ostringstream chain;
  for (int i = 0; i < kPoses; ++i) chain << "VERTEX_SE2 " << i << " " << i << " 0 0\n";
  for (int i = 0; i + 1 < kPoses; ++i)
    chain << "EDGE_SE2 " << i << " " << i + 1 << " 1 0 0 1 0 0 1 0 1\n";
  const std::string data = testing::WriteTempFile("chain300.g2o", chain.str());
  const std::string config =
      testing::WriteTempFile("pacing.textproto", "publish { status_rate_hz: 20 }\n");
  const pid_t slamd =
      testing::Spawn({SLAMD_PATH, "--config", config, "--lcm-url", kUrl, "--log-level", "warn"});
  const testing::CommandRun run = testing::RunCommand(
      {SLAMCTL_PATH, "replay", data, "--lcm-url", kUrl, "--rate", std::to_string(kRate),
       "--wait-server", "10", "--settle-timeout", "10", "-q", "--json"},
      testing::Streams::kStdout, 60);
  kill(slamd, SIGTERM);
  EXPECT_EQ(testing::WaitExit(slamd), 0);
  ASSERT_EQ(run.exit_code, 0) << run.out;
  // Sent one by one, 1 ms apart, the poses mostly get an update each (slamd is idle between
  // them); in bursts they shared one update per ~5.
  const double updates = JsonNumber(run.out, "update_sequence");
  EXPECT_GE(updates, kPoses / 3) << run.out;  // 54 of 300 with the old wait
  EXPECT_GE(JsonNumber(run.out, "wall_s"), (kPoses - 1) / kRate) << run.out;
}

// A slamd whose ingest queue holds one message refuses most of a fast replay (queue_full).
// The replay sends each refused message again and sends nothing new while one waits: every pose
// gets in, nothing is rejected. Without re-sends the refusals stand, and the odometry held
// behind the gaps they leave never connects.
TEST(ReplayPacingNetnsTest, RefusedMessagesAreSentAgainAndAllArrive) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  constexpr int kPoses = 600;
  std::ostringstream graph;
  for (int i = 0; i < kPoses; ++i) graph << "VERTEX_SE2 " << i << " " << i << " 0 0\n";
  for (int i = 0; i + 1 < kPoses; ++i)
    graph << "EDGE_SE2 " << i << " " << i + 1 << " 1 0 0 1 0 0 1 0 1\n";
  for (int i = 10; i < kPoses; i += 7)
    graph << "EDGE_SE2 " << i - 10 << " " << i << " 10 0 0 1 0 0 1 0 1\n";
  const std::string data = testing::WriteTempFile("loops600.g2o", graph.str());
  // Every update relinearises every variable, so the estimator falls behind 50,000 messages
  // per second; held messages wait as long as it takes (the test is about the refusals, not
  // the hold's bound).
  const std::string config = testing::WriteTempFile(
      "queue1.textproto",
      "queue { depth: 1 block_timeout_s: 0 }\nestimator { max_hold_updates: 1000000 }\n"
      "isam2 { relinearization { rotation_threshold: 1e-12 translation_threshold: 1e-12 "
      "skip: 1 } }\n");
  const auto replay = [&](const std::string& resend_for) {
    const pid_t slamd =
        testing::Spawn({SLAMD_PATH, "--config", config, "--lcm-url", kUrl, "--log-level", "error"});
    const testing::CommandRun run = testing::RunCommand(
        {SLAMCTL_PATH, "replay", data, "--lcm-url", kUrl, "--rate", "50000", "--resend-for",
         resend_for, "--wait-server", "10", "--settle-timeout", "10", "-q", "--json"},
        testing::Streams::kStdout, 120);
    kill(slamd, SIGTERM);
    EXPECT_EQ(testing::WaitExit(slamd), 0);
    return run;
  };
  const testing::CommandRun resent = replay("60");
  EXPECT_EQ(resent.exit_code, 0) << resent.out;
  EXPECT_GT(JsonNumber(resent.out, "resent"), 0) << resent.out;
  EXPECT_EQ(JsonNumber(resent.out, "rejected"), 0) << resent.out;
  EXPECT_EQ(JsonNumber(resent.out, "poses_acknowledged"), kPoses) << resent.out;
  const testing::CommandRun refused = replay("0");
  EXPECT_NE(refused.exit_code, 0) << refused.out;
  EXPECT_GT(JsonNumber(refused.out, "rejected"), 0) << refused.out;
  EXPECT_LT(JsonNumber(refused.out, "poses_acknowledged"), kPoses) << refused.out;
}

}  // namespace
}  // namespace slamd::server
