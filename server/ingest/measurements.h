// Inbound messages in core types, as conversion.h produces them from valid LCM messages.
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

#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"

namespace slamd::server {

// The values of these enums are the wire constants of the LCM types (static_asserts in
// conversion.cc).
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
  kPrior = 4
};
enum class KeyKind : std::int8_t { kPose = 1, kLandmark = 2 };

// A relative pose: Pose2 for 2D messages, Pose3 for 3D ones.
using RelativePose = std::variant<core::Pose2, core::Pose3>;

// BearingRangeFactor's measurement: bearing [rad] from the pose's x axis, range [m] >= 0.
struct BearingRange {
  double bearing = 0.0;
  double range = 0.0;
};

struct OdometryMeasurement {
  std::int64_t utime;
  std::string robot;
  std::uint64_t from_index;
  std::uint64_t to_index;
  RelativePose measured;   // pose to_index in the frame of pose from_index -> BetweenFactor
  core::NoiseModel noise;  // dim 3 or 6
};

struct LandmarkMeasurement {
  std::int64_t utime;
  std::string robot;
  std::uint64_t pose_index;
  std::uint64_t landmark_id;  // in `robot`'s namespace
  LandmarkKind kind;
  // kBearingRange2 -> BearingRange (BearingRangeFactor); kRelativePoint2 -> Point2,
  // kRelativePoint3 -> Point3 (RelativePointFactor), in the pose's frame.
  std::variant<BearingRange, core::Point2, core::Point3> measured;
  core::NoiseModel noise;  // dim 2, 2 or 3
};

struct LoopClosureMeasurement {
  std::int64_t utime;
  std::string robot_a;
  std::uint64_t pose_a;
  std::string robot_b;
  std::uint64_t pose_b;
  RelativePose measured;      // pose b in the frame of pose a -> BetweenFactor
  core::NoiseModel noise;     // dim 3 or 6
  core::RobustKernel robust;  // kNone unless the message named one
};

struct PriorMeasurement {
  std::int64_t utime;
  std::string robot;
  std::uint64_t pose_index;
  PriorKind kind;
  // kPose2 -> Pose2, kPose3 -> Pose3 (PriorFactor); kPosition2 -> Point2, kPosition3 -> Point3
  // (PositionPriorFactor<Pose2 / Pose3>), world frame.
  std::variant<core::Pose2, core::Pose3, core::Point2, core::Point3> measured;
  core::NoiseModel noise;  // dim 3, 6, 2 or 3
};

// Retracts the measurement with these identifying fields (table in msgs/lcm/remove_factor_t.lcm).
struct RemoveFactorRequest {
  std::int64_t utime = 0;
  RemoveTarget target = RemoveTarget::kOdometry;
  std::string robot_a;
  std::uint64_t index_a = 0;
  std::string robot_b;        // loop closures only
  std::uint64_t index_b = 0;  // to_index, landmark_id or pose_b; 0 for priors
  std::int8_t kind = 0;       // LandmarkKind / PriorKind value, 0 otherwise
};

// A variable named as on the wire (slamd.key_t).
struct WireKey {
  std::string robot;
  KeyKind kind = KeyKind::kPose;
  std::uint64_t index = 0;

  bool operator==(const WireKey&) const = default;
};

struct QueryRequest {
  std::int64_t utime = 0;
  std::string client;
  std::int64_t request_id = 0;
  std::vector<WireKey> keys = {};
  bool want_marginals = false;
  bool want_joint_marginal = false;
  std::string map_robot = "";  // "" none, "*" all, or a robot name
};

}  // namespace slamd::server
