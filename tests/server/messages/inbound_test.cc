// The list of inbound message specs: what the server derives from it (type names, lookups by
// value and LCM class, roles, the journal codec) agrees with each spec and its LCM class.
#include "server/messages/inbound.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <type_traits>

#include "server/messages/inbound_codec.h"
#include "tests/server/ingest/test_messages.h"

namespace slamd::server {
namespace {

namespace t = ::slamd::server::testing;

TEST(InboundSpecs, EachSpecNamesItsLcmClassAndIsFoundByValueAndByClass) {
  int count = 0;
  InboundSpecs::ForEach([&](auto spec) {
    using Spec = typename decltype(spec)::type;
    EXPECT_EQ(std::string(Spec::kType), Spec::Lcm::getTypeName());
    static_assert(std::is_same_v<SpecOf<typename Spec::Value>, Spec>);
    static_assert(std::is_same_v<SpecOfLcm<typename Spec::Lcm>, Spec>);
    ++count;
  });
  EXPECT_EQ(count, static_cast<int>(std::variant_size_v<InboundSpecs::Variant>));
  const std::vector<std::string>& names = InboundTypeNames();
  EXPECT_EQ(names.size(), static_cast<size_t>(count));
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size());
}

// Converts an example LCM message into an Inbound, as the daemon's intake does.
template <typename Msg>
Inbound FromLcm(const Msg& msg) {
  auto checked = Convert(msg);
  EXPECT_TRUE(checked.ok()) << checked.verdict().message;
  return Inbound{std::move(checked).value(), 0};
}

TEST(InboundSpecs, NamesRobotsAndRolesComeFromTheSpecs) {
  const Inbound odometry = FromLcm(t::Odometry2());
  EXPECT_STREQ(MessageTypeName(odometry), "odometry_t");
  EXPECT_EQ(MessageRobot(odometry), t::Odometry2().robot);
  EXPECT_EQ(MessageRoleOf(odometry), MessageRole::kMeasurement);
  EXPECT_EQ(MessageUtime(odometry), t::Odometry2().utime);

  const Inbound loop = FromLcm(t::LoopClosure2());
  EXPECT_EQ(MessageRobot(loop), t::LoopClosure2().robot_a);
  const Inbound removal = FromLcm(t::RemoveFactor(1));
  EXPECT_EQ(MessageRoleOf(removal), MessageRole::kRetraction);
  const Inbound query = FromLcm(t::Query());
  EXPECT_EQ(MessageRoleOf(query), MessageRole::kQuery);
  EXPECT_EQ(MessageRobot(query), t::Query().client);
}

TEST(InboundCodec, EveryTypeRoundTripsThroughItsSpec) {
  std::vector<Inbound> examples = {FromLcm(t::Odometry2()),
                                   FromLcm(t::Odometry3()),
                                   FromLcm(t::LoopClosure3()),
                                   FromLcm(t::Query()),
                                   FromLcm(t::RemoveFactor(3)),
                                   FromLcm(t::Landmark(1)),
                                   FromLcm(t::Prior(2)),
                                   FromLcm(t::CameraInfoMessage(4)),
                                   FromLcm(t::FrameMessage(2, true)),
                                   FromLcm(t::ShardSummary())};
  std::set<std::string> types;
  for (const Inbound& in : examples) {
    std::string type;
    const std::vector<std::uint8_t> bytes = EncodeInbound(in, &type);
    EXPECT_EQ(type, MessageTypeName(in));
    types.insert(type);
    core::Result<Inbound> back = DecodeInbound(type, bytes);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    // The same message (values round-trip through the noise model and quaternions to rounding,
    // so the bytes may differ in the last bits).
    std::string type_again;
    const std::vector<std::uint8_t> again = EncodeInbound(back.value(), &type_again);
    EXPECT_EQ(type_again, type);
    EXPECT_EQ(again.size(), bytes.size()) << type;
    EXPECT_EQ(MessageRobot(back.value()), MessageRobot(in));
    EXPECT_EQ(MessageUtime(back.value()), MessageUtime(in));
  }
  EXPECT_EQ(types.size(), InboundTypeNames().size());  // every type in the list
  EXPECT_EQ(DecodeInbound("nonsense_t", {}).status().code(), core::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace slamd::server
