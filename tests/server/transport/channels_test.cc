#include "server/transport/channels.h"

#include <gtest/gtest.h>

#include <set>

#include "server/transport/bus.h"

namespace slamd::server {
namespace {

std::vector<std::string> All(const ChannelNames& c) {
  return {c.Odometry(), c.Landmark(), c.LoopClosure(), c.Prior(),  c.RemoveFactor(), c.Query(),
          c.Estimate(), c.Map(),      c.Status(),      c.Reject(), c.QueryReply()};
}

TEST(ChannelNames, DefaultPrefix) {
  const ChannelNames c;
  EXPECT_EQ(c.Odometry(), "SLAMD_ODOMETRY");
  EXPECT_EQ(c.QueryReply(), "SLAMD_QUERY_REPLY");
  const auto all = All(c);
  EXPECT_EQ(std::set<std::string>(all.begin(), all.end()).size(), all.size());
}

TEST(ChannelNames, A40CharPrefixStaysWithinLcmsLimit) {
  const ChannelNames c{.prefix = std::string(40, 'P')};
  for (const std::string& name : All(c)) {
    EXPECT_EQ(name.rfind(c.prefix, 0), 0u);
    EXPECT_TRUE(CheckChannelName(name).ok()) << name;
  }
}

}  // namespace
}  // namespace slamd::server
