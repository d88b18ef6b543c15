// shard_summary_t (msgs/lcm/shard_summary_t.lcm): what a neighbouring map shard knows about the
// poses and shared-map landmarks it shares with this one (docs/SCALING.md), and which landmarks
// of the shared map it holds.
//
// Applied: a LinearContainerFactor on those variables that replaces the previous summary from
// the same shard in the same update. A shared pose of a robot this shard does not own and has
// not seen, or a landmark it does not hold, is added at the summary's x₀; one of its own robots'
// poses it has not seen yet holds the summary until that pose arrives. The landmark list goes to
// the shard's boundary (shard_boundary.h), also when the summary has no keys. A shard that is not
// the one named in to_shard rejects it (kUnknownRobot: "not this shard").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/variables/variable.h"
#include "server/ingest/conversion.h"
#include "server/ingest/measurements.h"
#include "server/messages/message_spec.h"
#include "slamd/shard_summary_t.hpp"

namespace slamd::server {

struct ShardSummaryMessage {
  std::int64_t utime = 0;
  std::string from_shard;
  std::string to_shard;
  std::vector<WireKey> keys;       // poses and shared-map landmarks (robot "")
  std::vector<core::Variable> x0;  // one per key: Pose2 / Point2, or Pose3 / Point3
  Eigen::MatrixXd A;               // rows x Σ tangent dims (0 x 0 without keys)
  Eigen::VectorXd b;
  std::vector<std::uint64_t> map_landmarks;  // the shared map's landmarks it holds, ascending
};

// Bounds of a summary: its keys (the rows of A are at most its columns), its landmark list.
inline constexpr int kMaxSummaryKeys = 4096;
inline constexpr int kMaxSummaryMapLandmarks = 100000;

Verdict Validate(const slamd::shard_summary_t& msg, const Limits& limits = {});
Checked<ShardSummaryMessage> Convert(const slamd::shard_summary_t& msg, const Limits& limits = {});
void ToLcm(const ShardSummaryMessage& m, slamd::shard_summary_t* out);

struct ShardSummarySpec {
  using Lcm = slamd::shard_summary_t;
  using Value = ShardSummaryMessage;
  static constexpr const char* kType = "shard_summary_t";
  static constexpr const char* kChannel = "SHARD_SUMMARY";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;
  static constexpr char kIdentity = 's';

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.from_shard;
  }
  // Addressed to a shard, not about a robot: only the shard named here takes it.
  template <typename M>
  static const std::string& Shard(const M& m) {
    return m.to_shard;
  }
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

// A stable number for a shard name (FNV-1a), the first key of a summary's MeasurementId.
core::Key ShardIdentity(const std::string& shard);

}  // namespace slamd::server
