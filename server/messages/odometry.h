// odometry_t (msgs/lcm/odometry_t.lcm): the relative pose between two poses of one robot.
//
// Applied: a BetweenFactor from from_index to to_index. The new pose's initial guess is
// estimate(from) ∘ z; or estimate(to) ∘ z⁻¹ when only the to-pose is known (a robot connected
// mid-trajectory by a loop closure gets its earlier poses backwards); a robot's first odometry
// places from_index at the origin with an anchor prior under AnchorPolicy::kAnchorAtOrigin.
// Held while neither pose is known (ahead of the next expected pose, or the robot unanchored).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/factors/noise_model.h"
#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/odometry_t.hpp"

namespace slamd::server {

struct OdometryMeasurement {
  std::int64_t utime;
  std::string robot;
  std::uint64_t from_index;
  std::uint64_t to_index;
  RelativePose measured;   // pose to_index in the frame of pose from_index -> BetweenFactor
  core::NoiseModel noise;  // dim 3 or 6
};

// `noise` (optional) receives the noise model built from the covariance when accepted.
Verdict Validate(const slamd::odometry_t& msg, const Limits& limits = {},
                 std::optional<core::NoiseModel>* noise = nullptr);
Checked<OdometryMeasurement> Convert(const slamd::odometry_t& msg, const Limits& limits = {});
void ToLcm(const OdometryMeasurement& m, slamd::odometry_t* out);

struct OdometrySpec {
  using Lcm = slamd::odometry_t;
  using Value = OdometryMeasurement;
  static constexpr const char* kType = "odometry_t";
  static constexpr const char* kChannel = "ODOMETRY";  // after the channel prefix
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 'o';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot;
  }
  static core::FactorPtr Factor(const Value& m, core::Key from, core::Key to);
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
