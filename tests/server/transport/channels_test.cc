#include "server/transport/channels.h"

#include <gtest/gtest.h>

#include <set>

#include "server/messages/inbound.h"
#include "server/transport/bus.h"

namespace slamd::server {
namespace {

// Every inbound type's channel (from the list of specs) and the outbound ones.
std::vector<std::string> All(const ChannelNames& c) {
  std::vector<std::string> all = {c.Estimate(), c.Map(), c.Status(), c.Reject(), c.QueryReply()};
  InboundSpecs::ForEach(
      [&](auto spec) { all.push_back(c.Inbound<typename decltype(spec)::type>()); });
  return all;
}

TEST(ChannelNames, DefaultPrefix) {
  const ChannelNames c;
  EXPECT_EQ(c.Inbound<OdometrySpec>(), "SLAMD_ODOMETRY");
  EXPECT_EQ(c.Inbound<QuerySpec>(), "SLAMD_QUERY");
  EXPECT_EQ(c.QueryReply(), "SLAMD_QUERY_REPLY");
  const auto all = All(c);
  EXPECT_EQ(all.size(), 14u);
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
