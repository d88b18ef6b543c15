// remove_factor_t (msgs/lcm/remove_factor_t.lcm): retracts an applied measurement, named by its
// identifying fields (the table in the .lcm file). The estimator applies it in an update of its
// own, so a removal the solver refuses (kWouldDisconnect) rejects nothing else.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/remove_factor_t.hpp"

namespace slamd::server {

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

Verdict Validate(const slamd::remove_factor_t& msg, const Limits& limits = {});
Checked<RemoveFactorRequest> Convert(const slamd::remove_factor_t& msg, const Limits& limits = {});
void ToLcm(const RemoveFactorRequest& m, slamd::remove_factor_t* out);

struct RemoveFactorSpec {
  using Lcm = slamd::remove_factor_t;
  using Value = RemoveFactorRequest;
  static constexpr const char* kType = "remove_factor_t";
  static constexpr const char* kChannel = "REMOVE_FACTOR";
  static constexpr MessageRole kRole = MessageRole::kRetraction;

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot_a;
  }
  // The identity of the measurement it names, and in *first the key that measurement named
  // first (loop closures are directed); nullopt with *why when a robot is unknown.
  static std::optional<MeasurementId> Identity(const Value& r, const GraphBuilder& graph,
                                               core::Key* first, std::string* why);
};

}  // namespace slamd::server
