// A map shard's boundary (docs/SCALING.md): the variables its summary is on. Both ends of its own
// factors that name another shard's pose, its own poses in the summaries other shards sent, and
// the shared map's landmarks that its own factors name and another shard holds (the lists the
// summaries carry; kept since the last summary of each shard, not in snapshots).
// It grows as factors are applied (so a journal replayed after a crash grows it as the live run
// did) and keeps a pose while the graph has it: one whose closure was retracted stays, as the
// other shards may hold it only through this shard's summaries. Kept in snapshots.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "core/factors/factor_graph.h"
#include "core/factors/values.h"
#include "server/estimator/robot_registry.h"
#include "server/ingest/shard_map.h"
#include "server/messages/message_spec.h"

namespace slamd::server {

class ShardBoundary {
 public:
  // Whose poses are another shard's: `shards` and `robots` must outlive this.
  ShardBoundary(const ShardMap& shards, const RobotRegistry& robots)
      : shards_(shards), robots_(robots) {}

  // Grows it by one factor (`received_summary`: a summary another shard sent).
  void Grow(const core::Factor& f, bool received_summary);
  // Grows it by the factors of an applied update: (position in `factors`, id, first key) of each
  // measured one, whose id says which are received summaries. No-op when not sharded.
  void Grow(const core::FactorGraph& factors,
            std::span<const std::tuple<std::size_t, MeasurementId, core::Key>> ids);
  // Drops the poses `graph` no longer has (removed variables).
  void KeepOnly(const core::Values& graph);
  // The shared map's landmarks `shard` holds (its latest list replaces the one before).
  void NoteLandmarks(const std::string& shard, const std::vector<std::uint64_t>& landmarks);
  // Grows it by those of `own` (the shared map's landmarks its own factors name) another shard
  // holds.
  void GrowShared(const std::set<std::uint64_t>& own);

  const std::set<core::Key>& keys() const { return keys_; }
  template <typename It>
  void Insert(It begin, It end) {  // restoring a snapshot's
    keys_.insert(begin, end);
  }

 private:
  bool Foreign(core::Key k) const;  // a pose of another shard's robot

  const ShardMap& shards_;
  const RobotRegistry& robots_;
  std::set<core::Key> keys_;
  std::map<std::string, std::set<std::uint64_t>> landmarks_of_;  // by shard
};

}  // namespace slamd::server
