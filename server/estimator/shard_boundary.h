// A map shard's boundary (docs/SCALING.md): the poses its summary is on. Both ends of its own
// factors that name another shard's pose, and its own poses in the summaries other shards sent.
// It grows as factors are applied (so a journal replayed after a crash grows it as the live run
// did) and keeps a pose while the graph has it: one whose closure was retracted stays, as the
// other shards may hold it only through this shard's summaries. Kept in snapshots.
#pragma once

#include <cstddef>
#include <set>
#include <span>
#include <tuple>

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
};

}  // namespace slamd::server
