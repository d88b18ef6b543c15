// `slamctl query` argument errors (exit 2) and a timeout without a server (exit 1). The round
// trip itself is tested against a fake server in query_client_test.cc.
#include <gtest/gtest.h>

#include "tests/clients/slamctl/slamctl_runner.h"

namespace slamd::clients {
namespace {

using testing::ExpectUsageError;
using testing::RunSlamctl;

TEST(QueryCommandTest, ArgumentErrorsExit2) {
  ExpectUsageError("query", "", "give at least one KEY");
  ExpectUsageError("query", "x12", "key 'x12': no robot");
  ExpectUsageError("query", "bot:y3", "no x or l index");
  ExpectUsageError("query", "bot:x1a", "index is not a number");
  ExpectUsageError("query", "'bad name:x1'", "robot name");
  ExpectUsageError("query", "--joint a:x1 a:x2 a:x3 a:x4 a:x5 a:x6 a:x7 a:x8 a:x9 a:x10 a:x11",
                   "--joint takes at most 10 keys");
  ExpectUsageError("query", "--map 'a b'", "--map 'a b'");
  ExpectUsageError("query", "a:x1 --timeout 0", "--timeout");
}

TEST(QueryCommandTest, NoReplyExits1) {
  const testing::SlamctlRun run =
      RunSlamctl("query --robot bot x3 l4 --lcm-url memq:// --timeout 0.2");
  EXPECT_EQ(run.exit_code, 1) << run.out;
  EXPECT_NE(run.out.find("timed out: no query_reply_t"), std::string::npos) << run.out;
}

}  // namespace
}  // namespace slamd::clients
