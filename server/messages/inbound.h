// The inbound message types, listed once. The Inbound variant, the daemon's subscriptions, the
// journal codec (inbound_codec.h), type names, channels and the fuzz targets all come from
// InboundSpecs; nothing indexes the variant by position.
//
// To add a message type: its msgs/lcm/<type>.lcm, its spec server/messages/<type>.h/.cc
// (message_spec.h says what a spec declares), its include and entry below, and tests.
#pragma once

#include <cstdint>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "server/messages/camera_info.h"
#include "server/messages/frame_observations.h"
#include "server/messages/landmark_observation.h"
#include "server/messages/loop_closure.h"
#include "server/messages/odometry.h"
#include "server/messages/prior.h"
#include "server/messages/query.h"
#include "server/messages/remove_factor.h"
#include "server/messages/shard_summary.h"

namespace slamd::server {

template <typename... Specs>
struct SpecList {
  using Variant = std::variant<typename Specs::Value...>;
  // f(std::type_identity<Spec>{}) for each spec, in list order.
  template <typename F>
  static void ForEach(F&& f) {
    (f(std::type_identity<Specs>{}), ...);
  }
};

using InboundSpecs =
    SpecList<OdometrySpec, LandmarkObservationSpec, LoopClosureSpec, PriorSpec, RemoveFactorSpec,
             QuerySpec, CameraInfoSpec, FrameObservationsSpec, ShardSummarySpec>;

namespace internal {
// The first spec S of the list with Member<S> = T.
template <template <typename> class Member, typename T, typename... Specs>
struct FindSpec;
template <template <typename> class Member, typename T, typename First, typename... Rest>
struct FindSpec<Member, T, First, Rest...>
    : std::conditional_t<std::is_same_v<T, Member<First>>, std::type_identity<First>,
                         FindSpec<Member, T, Rest...>> {};
template <template <typename> class Member, typename T, typename List>
struct FindInList;
template <template <typename> class Member, typename T, typename... Specs>
struct FindInList<Member, T, SpecList<Specs...>> : FindSpec<Member, T, Specs...> {};
template <typename S>
using ValueOf = typename S::Value;
template <typename S>
using LcmOf = typename S::Lcm;
}  // namespace internal

// The spec whose Value is V (OdometrySpec for OdometryMeasurement, ...), and the spec of an LCM
// class (OdometrySpec for slamd::odometry_t).
template <typename V>
using SpecOf =
    typename internal::FindInList<internal::ValueOf, std::decay_t<V>, InboundSpecs>::type;
template <typename L>
using SpecOfLcm =
    typename internal::FindInList<internal::LcmOf, std::decay_t<L>, InboundSpecs>::type;

// One inbound message with its transport receipt time [µs, steady clock]: a measurement, a
// retraction, or a query (queries go through the same queue so they see every message queued
// before them; the daemon answers them, the estimator never sees one).
struct Inbound {
  InboundSpecs::Variant measurement;
  std::int64_t received_us = 0;
  // Its journal sequence number (1, 2, ...); 0 when not journaled (no data_dir, or a query).
  std::int64_t journal_sequence = 0;
};

// f(std::type_identity<Spec>{}, value) with the message's spec and value.
template <typename F>
decltype(auto) VisitSpec(const Inbound& in, F&& f) {
  return std::visit(
      [&](const auto& m) -> decltype(auto) {
        return f(std::type_identity<SpecOf<decltype(m)>>{}, m);
      },
      in.measurement);
}

// Whether a sharded slamd takes a message (LCM class or value of spec S): a summary addressed
// to its shard (S::Shard), a query it is among the answering shards of (S::AnsweringShards), or
// a message whose robot (S::Robot: robot_a of a loop closure) it owns. Unsharded, every message.
template <typename S, typename M>
bool ForThisShard(const ShardMap& shards, const M& m) {
  if (!shards.sharded()) return true;
  if constexpr (requires { S::Shard(m); }) {
    return S::Shard(m) == shards.self;
  } else if constexpr (requires { S::AnsweringShards(shards, m); }) {
    return S::AnsweringShards(shards, m).count(shards.self) != 0;
  } else {
    return shards.Owns(S::Robot(m));
  }
}

// The spec's kType ("odometry_t", ...), Robot (robot_a for loop closures and removals, the
// client for queries), kRole, and the message's utime.
const char* MessageTypeName(const Inbound& in);
// Every spec's kType, in list order (fuzz targets pick a type by its position here).
const std::vector<std::string>& InboundTypeNames();
const std::string& MessageRobot(const Inbound& in);
MessageRole MessageRoleOf(const Inbound& in);
std::int64_t MessageUtime(const Inbound& in);

}  // namespace slamd::server
