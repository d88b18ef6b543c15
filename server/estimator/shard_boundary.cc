#include "server/estimator/shard_boundary.h"

#include <algorithm>
#include <vector>

#include "server/messages/shard_summary.h"

namespace slamd::server {

bool ShardBoundary::Foreign(core::Key k) const {
  return core::KeySymbol(k) == 'x' && !shards_.Owns(robots_.Name(core::KeyRobot(k)));
}

void ShardBoundary::Grow(const core::Factor& f, bool received_summary) {
  const std::span<const core::Key> keys = f.keys();
  if (received_summary) {
    for (core::Key k : keys) {
      if (core::KeySymbol(k) == 'x' && !Foreign(k)) keys_.insert(k);
    }
  } else if (std::any_of(keys.begin(), keys.end(), [&](core::Key k) { return Foreign(k); })) {
    for (core::Key k : keys) {
      if (core::KeySymbol(k) == 'x') keys_.insert(k);
    }
  }
}

void ShardBoundary::Grow(const core::FactorGraph& factors,
                         std::span<const std::tuple<std::size_t, MeasurementId, core::Key>> ids) {
  if (!shards_.sharded()) return;
  std::vector<bool> received(factors.size(), false);
  for (const auto& [position, id, first] : ids) {
    received[position] = std::get<0>(id) == ShardSummarySpec::kIdentity;
  }
  for (std::size_t i = 0; i < factors.size(); ++i) Grow(*factors[i], received[i]);
}

void ShardBoundary::NoteLandmarks(const std::string& shard,
                                  const std::vector<std::uint64_t>& landmarks) {
  landmarks_of_[shard] = std::set<std::uint64_t>(landmarks.begin(), landmarks.end());
}

void ShardBoundary::GrowShared(const std::set<std::uint64_t>& own) {
  for (const auto& [shard, theirs] : landmarks_of_) {
    for (std::uint64_t id : own) {
      if (theirs.contains(id)) keys_.insert(MapLandmarkKey(id));
    }
  }
}

void ShardBoundary::KeepOnly(const core::Values& graph) {
  std::erase_if(keys_, [&](core::Key k) { return !graph.Contains(k); });
}

}  // namespace slamd::server
