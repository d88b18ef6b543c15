// The list of inbound message specs: what the server derives from it (type names, lookups by
// value and LCM class, roles, the journal codec) agrees with each spec and its LCM class.
#include "server/messages/inbound.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <type_traits>

#include "server/messages/inbound_codec.h"
#include "slamd_legacy/landmark_observation_v1_t.hpp"
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

// Journals, snapshots and logs written before landmark_observation_t had landmark_namespace
// still decode: as the robot's namespace, the only one that layout had.
TEST(InboundCodec, TheLandmarkLayoutBeforeNamespacesIsReadAsTheRobotsNamespace) {
  const slamd::landmark_observation_t now = t::Landmark(2);
  slamd_legacy::landmark_observation_v1_t old;
  old.utime = now.utime;
  old.robot = now.robot;
  old.pose_index = now.pose_index;
  old.landmark_id = now.landmark_id;
  old.kind = now.kind;
  old.num_values = now.num_values;
  old.values = now.values;
  old.num_covariance = now.num_covariance;
  old.covariance = now.covariance;
  ASSERT_NE(old.getHash(), now.getHash());
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(old.getEncodedSize()));
  ASSERT_EQ(old.encode(bytes.data(), 0, static_cast<int>(bytes.size())),
            static_cast<int>(bytes.size()));

  core::Result<Inbound> decoded = DecodeInbound("landmark_observation_t", bytes);
  ASSERT_TRUE(decoded.ok()) << decoded.status().ToString();
  const auto* m = std::get_if<LandmarkMeasurement>(&decoded->measurement);
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->landmark_namespace, LandmarkNamespace::kRobot);
  EXPECT_EQ(m->robot, now.robot);
  EXPECT_EQ(m->landmark_id, 17u);
  EXPECT_EQ(m->kind, LandmarkKind::kRelativePoint2);
  EXPECT_EQ(std::get<core::Point2>(m->measured), core::Point2(3.0, -1.5));
  // Re-encoded, it is the current layout.
  std::string type;
  const std::vector<std::uint8_t> again = EncodeInbound(*decoded, &type);
  EXPECT_EQ(again.size(), bytes.size() + 1);  // the namespace byte
  EXPECT_TRUE(DecodeInbound(type, again).ok());

  // Broken bytes of the old layout are a decode error naming it.
  bytes.pop_back();
  const core::Status truncated = DecodeInbound("landmark_observation_t", bytes).status();
  EXPECT_EQ(truncated.code(), core::StatusCode::kDataLoss);
  EXPECT_NE(truncated.message().find("older layout"), std::string::npos) << truncated.message();
}

}  // namespace
}  // namespace slamd::server
