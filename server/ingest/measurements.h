// The parts of inbound messages in core types that several message types share (each type's
// value is in its spec, server/messages/<type>.h).
//
// Variables are still named by robot name and index (not core Keys): the estimator owns the
// robot-name -> robot-id table and builds keys as core::MakeKey('x' | 'l', index, robot_id).
// Every measurement keeps the sender's utime (µs) for journaling and latency accounting.
// Frames, units and tangent orders are those of msgs/lcm (translation first, right perturbation).
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "core/base/key.h"
#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"

namespace slamd::server {

// The values of these enums are the wire constants of the LCM types (static_asserts in the
// message specs, server/messages/).
enum class LandmarkKind : std::int8_t {
  kBearingRange2 = 1,
  kRelativePoint2 = 2,
  kRelativePoint3 = 3
};
enum class PriorKind : std::int8_t { kPose2 = 1, kPose3 = 2, kPosition2 = 3, kPosition3 = 4 };
enum class RemoveTarget : std::int8_t {
  kOdometry = 1,
  kLandmarkObservation = 2,
  kLoopClosure = 3,
  kPrior = 4,
  kMapLandmarkObservation = 5
};
enum class KeyKind : std::int8_t { kPose = 1, kLandmark = 2, kMapLandmark = 3 };

// Whose landmark ids a message names: its robot's (key 'l' id of that robot) or the map's,
// shared by all robots (key 'm' id of robot id 0, which no robot has).
enum class LandmarkNamespace : std::int8_t { kRobot = 0, kMap = 1 };
inline constexpr char kMapLandmarkSymbol = 'm';
inline core::Key MapLandmarkKey(std::uint64_t id) {
  return core::MakeKey(kMapLandmarkSymbol, id, 0);
}
inline core::Key LandmarkKey(LandmarkNamespace ns, std::uint64_t id, std::uint8_t robot) {
  return ns == LandmarkNamespace::kMap ? MapLandmarkKey(id) : core::MakeKey('l', id, robot);
}
// "landmark 17 of robot 'a'" or "map landmark 17", for messages.
inline std::string LandmarkName(LandmarkNamespace ns, const std::string& robot, std::uint64_t id) {
  return ns == LandmarkNamespace::kMap
             ? "map landmark " + std::to_string(id)
             : "landmark " + std::to_string(id) + " of robot '" + robot + "'";
}

// A relative pose: Pose2 for 2D messages, Pose3 for 3D ones.
using RelativePose = std::variant<core::Pose2, core::Pose3>;

// BearingRangeFactor's measurement: bearing [rad] from the pose's x axis, range [m] >= 0.
struct BearingRange {
  double bearing = 0.0;
  double range = 0.0;
};

// A variable named as on the wire (slamd.key_t): robot "" for a shared map landmark.
struct WireKey {
  std::string robot;
  KeyKind kind = KeyKind::kPose;
  std::uint64_t index = 0;

  bool operator==(const WireKey&) const = default;
};

// "robot:x12" (a pose), "robot:l3" (a landmark) or "m7" (a landmark of the shared map).
inline std::string WireKeyName(const WireKey& k) {
  if (k.kind == KeyKind::kMapLandmark) return "m" + std::to_string(k.index);
  return k.robot + ":" + (k.kind == KeyKind::kPose ? "x" : "l") + std::to_string(k.index);
}

}  // namespace slamd::server
