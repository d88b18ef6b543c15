// `slamctl query` argument errors (exit 2) and a timeout without a server (exit 1). The round
// trip itself is tested against a fake server in query_client_test.cc.
#include <gtest/gtest.h>

#include "tests/clients/slamctl/slamctl_runner.h"

namespace slamd::clients {
namespace {

using testing::RunSlamctl;

void ExpectUsage(const std::string& args, const std::string& message) {
  const testing::SlamctlRun run = RunSlamctl("query " + args);
  EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.out;
  EXPECT_NE(run.out.find(message), std::string::npos) << args << "\n" << run.out;
}

TEST(QueryCommandTest, ArgumentErrorsExit2) {
  ExpectUsage("", "give at least one KEY");
  ExpectUsage("x12", "key 'x12': no robot");
  ExpectUsage("bot:y3", "no x or l index");
  ExpectUsage("bot:x1a", "index is not a number");
  ExpectUsage("'bad name:x1'", "robot name");
  ExpectUsage("--joint a:x1 a:x2 a:x3 a:x4 a:x5 a:x6 a:x7 a:x8 a:x9 a:x10 a:x11",
              "--joint takes at most 10 keys");
  ExpectUsage("--map 'a b'", "--map 'a b'");
  ExpectUsage("a:x1 --timeout 0", "--timeout");
}

TEST(QueryCommandTest, NoReplyExits1) {
  const testing::SlamctlRun run =
      RunSlamctl("query --robot bot x3 l4 --lcm-url memq:// --timeout 0.2");
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("timed out: no query_reply_t"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace slamd::clients
