// landmark_observation_t (msgs/lcm/landmark_observation_t.lcm): a landmark seen from a pose, as
// bearing and range (2D) or a point in the pose's frame (2D or 3D).
//
// Applied: a BearingRangeFactor or RelativePointFactor; a new landmark is placed by this first
// observation from the pose's estimate. Held while the pose is unknown. Landmark ids are in the
// observing robot's namespace or in the map namespace all robots share.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/landmark_observation_t.hpp"

namespace slamd::server {

struct LandmarkMeasurement {
  std::int64_t utime;
  std::string robot;
  std::uint64_t pose_index;
  std::uint64_t landmark_id;  // in `landmark_namespace`
  LandmarkKind kind;
  // kBearingRange2 -> BearingRange (BearingRangeFactor); kRelativePoint2 -> Point2,
  // kRelativePoint3 -> Point3 (RelativePointFactor), in the pose's frame.
  std::variant<BearingRange, core::Point2, core::Point3> measured;
  core::NoiseModel noise;  // dim 2, 2 or 3
  LandmarkNamespace landmark_namespace = LandmarkNamespace::kRobot;
};

Verdict Validate(const slamd::landmark_observation_t& msg, const Limits& limits = {},
                 std::optional<core::NoiseModel>* noise = nullptr);
Checked<LandmarkMeasurement> Convert(const slamd::landmark_observation_t& msg,
                                     const Limits& limits = {});
void ToLcm(const LandmarkMeasurement& m, slamd::landmark_observation_t* out);

struct LandmarkObservationSpec {
  using Lcm = slamd::landmark_observation_t;
  using Value = LandmarkMeasurement;
  static constexpr const char* kType = "landmark_observation_t";
  static constexpr const char* kChannel = "LANDMARK";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 'l';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot;
  }
  static core::FactorPtr Factor(const Value& m, core::Key pose, core::Key landmark);
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
