// `slamctl replay` argument errors (exit 2 with a message that says what to do) and failures
// without a server (exit 1). No UDP: errors come before connecting, or the bus is memq://.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/clients/slamctl/slamctl_runner.h"
#include "tests/testing/datasets.h"

namespace slamd::clients {
namespace {

using testing::ExpectUsageError;
using testing::RunSlamctl;

const std::string kData = testing::TestDataPath("small_slam2d.g2o");

TEST(ReplayCommandTest, ArgumentErrorsExit2WithAHelpfulMessage) {
  ExpectUsageError("replay", "", "source is required");
  ExpectUsageError("replay", "/nonexistent.g2o", "does not exist");
  ExpectUsageError("replay", kData + " --fast --lockstep",
                   "choose one of --rate, --fast and --lockstep");
  ExpectUsageError("replay", kData + " --rate 10 --fast", "choose one of");
  ExpectUsageError("replay", kData + " --rate -1", "--rate");
  ExpectUsageError("replay", kData + " --robot a --robot b",
                   "--robot given 2 times for 1 datasets");
  ExpectUsageError("replay", kData + " " + kData, "two datasets are both robot 'small_slam2d'");
  ExpectUsageError("replay", kData + " --robot 'bad name'", "robot name 'bad name'");
  ExpectUsageError("replay", kData + " --speed 2", "--speed scales LCM log time");
  ExpectUsageError("replay", kData + " --channels 'X.*'",
                   "--channels selects channels of an LCM log");
  ExpectUsageError("replay", kData + " --window 0", "--window must be >= 1");
  ExpectUsageError("replay", kData + " --channel-prefix 'a-b'", "--channel-prefix 'a-b'");
}

TEST(ReplayCommandTest, LogsAreDetectedByContentNotByName) {
  // A file named .lcm that is a dataset replays as a dataset: the --channels error proves it.
  std::ifstream in(kData);
  std::stringstream text;
  text << in.rdbuf();
  const std::string fake_log = testing::WriteTempFile("looks_like.lcm", text.str());
  ExpectUsageError("replay", fake_log + " --channels 'X.*'",
                   "--channels selects channels of an LCM log");
  // A real log (sync word 0xEDA1DA01) is refused next to a dataset.
  const std::string log =
      testing::WriteTempFile("recorded.g2o", std::string("\xED\xA1\xDA\x01", 4));
  ExpectUsageError("replay", log + " " + kData, "mix of LCM logs and datasets");
  ExpectUsageError("replay", log + " --robot a", "--robot names dataset robots");
}

TEST(ReplayCommandTest, UnreadableInterRobotFileOrNoServerExit1) {
  const std::string bad = testing::WriteTempFile("inter.txt", "INTER_SE2 a 0 b\n");
  testing::SlamctlRun run = RunSlamctl("replay " + kData + " --inter-robot " + bad);
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("inter.txt:1: INTER_SE2 needs 14 fields"), std::string::npos) << run.out;

  // memq:// is an in-process bus: nobody answers, so --lockstep gives up after --ack-timeout.
  run = RunSlamctl("replay " + kData +
                   " --lcm-url memq:// --lockstep --ack-timeout 0.2 --wait-server 0 -q");
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("--lockstep: no estimate_t acknowledged the previous pose"),
            std::string::npos)
      << run.out;
  // --rate: everything is sent, then no status_t comes: exit 1, summary printed.
  run = RunSlamctl(
      "replay " + kData +
          " --lcm-url memq:// --rate 100000 --wait-server 0 --settle-timeout 0.2 -q --json",
      /*merge_stderr=*/false);
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("\"answered\": false"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("\"final_chi2\": null"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace slamd::clients
