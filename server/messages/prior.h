// prior_t (msgs/lcm/prior_t.lcm): an absolute pose or position of one pose, in the world frame.
//
// Applied: a PriorFactor (pose) or PositionPriorFactor (position). A pose prior on a robot with
// no pose yet places (and anchors) that pose; otherwise held while the pose is unknown.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/prior_t.hpp"

namespace slamd::server {

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

Verdict Validate(const slamd::prior_t& msg, const Limits& limits = {},
                 std::optional<core::NoiseModel>* noise = nullptr);
Checked<PriorMeasurement> Convert(const slamd::prior_t& msg, const Limits& limits = {});
void ToLcm(const PriorMeasurement& m, slamd::prior_t* out);

struct PriorSpec {
  using Lcm = slamd::prior_t;
  using Value = PriorMeasurement;
  static constexpr const char* kType = "prior_t";
  static constexpr const char* kChannel = "PRIOR";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 'p';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot;
  }
  static core::FactorPtr Factor(const Value& m, core::Key pose);
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
