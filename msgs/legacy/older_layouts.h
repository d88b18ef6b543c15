// Older layouts of inbound LCM types that slamd still reads (msgs/legacy/*.lcm), so that a
// journal, a snapshot or a log written before a type gained a field stays readable. LCM's
// fingerprint depends on a type's fields alone: bytes carrying an older layout's fingerprint
// are decoded as that layout and upgraded (the new field at the value the old meaning had).
//
// OlderLayout<Msg>::Type is void for a type without one; otherwise its Upgrade fills Msg.
#pragma once

#include <type_traits>
#include <utility>

#include "slamd/landmark_observation_t.hpp"
#include "slamd_legacy/landmark_observation_v1_t.hpp"

namespace slamd {

template <typename Msg>
struct OlderLayout {
  using Type = void;
};

// Before landmark_namespace: every landmark id was in the observing robot's namespace.
template <>
struct OlderLayout<landmark_observation_t> {
  using Type = slamd_legacy::landmark_observation_v1_t;
  static void Upgrade(Type&& old, landmark_observation_t* msg) {
    msg->utime = old.utime;
    msg->robot = std::move(old.robot);
    msg->pose_index = old.pose_index;
    msg->landmark_id = old.landmark_id;
    msg->kind = old.kind;
    msg->landmark_namespace = landmark_observation_t::NAMESPACE_ROBOT;
    msg->num_values = old.num_values;
    msg->values = std::move(old.values);
    msg->num_covariance = old.num_covariance;
    msg->covariance = std::move(old.covariance);
  }
};

template <typename Msg>
inline constexpr bool kHasOlderLayout = !std::is_void_v<typename OlderLayout<Msg>::Type>;

}  // namespace slamd
