// `slamctl watch`: runs for --duration on an in-process bus (memq://, nothing answers) and
// prints frames saying so; argument errors exit 2.
#include <gtest/gtest.h>

#include "tests/clients/slamctl/slamctl_runner.h"

namespace slamd::clients {
namespace {

using testing::RunSlamctl;

TEST(WatchCommandTest, RunsForItsDurationAndPrintsFrames) {
  const testing::SlamctlRun run =
      RunSlamctl("watch --lcm-url memq:// --duration 0.3 --period 0.1", /*merge_stderr=*/false);
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find("(no status_t yet)"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("(no estimate_t yet)"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("\x1b["), std::string::npos) << "no escape codes when not a terminal";
}

TEST(WatchCommandTest, ArgumentErrorsExit2) {
  EXPECT_EQ(RunSlamctl("watch --duration -1").exit_code, 2);
  EXPECT_EQ(RunSlamctl("watch --period 0").exit_code, 2);
  EXPECT_EQ(RunSlamctl("watch --channel-prefix '' --lcm-url memq://").exit_code, 2);
}

}  // namespace
}  // namespace slamd::clients
