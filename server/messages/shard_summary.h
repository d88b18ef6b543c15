// shard_summary_t (msgs/lcm/shard_summary_t.lcm): what a neighbouring map shard knows about the
// poses it shares with this one (docs/SCALING.md).
//
// Applied: a LinearContainerFactor on those poses that replaces the previous summary from the
// same shard in the same update. A shared pose of a robot this shard does not own and has not
// seen is added at the summary's x₀; one of its own robots' poses it has not seen yet holds the
// summary until that pose arrives. A shard that is not the one named in to_shard rejects it
// (kUnknownRobot: "not this shard").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/variables/variable.h"
#include "server/ingest/conversion.h"
#include "server/messages/message_spec.h"
#include "slamd/shard_summary_t.hpp"

namespace slamd::server {

struct ShardSummaryMessage {
  std::int64_t utime = 0;
  std::string from_shard;
  std::string to_shard;
  std::vector<std::pair<std::string, std::uint64_t>> poses;  // (robot, pose index)
  std::vector<core::Variable> x0;                            // Pose2 or Pose3, one per pose
  Eigen::MatrixXd A;                                         // rows x Σ tangent dims
  Eigen::VectorXd b;
};

// Bounds of a summary: poses, and the rows of A (at most its columns).
inline constexpr int kMaxSummaryPoses = 4096;

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
