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

}  // namespace
}  // namespace slamd::server
