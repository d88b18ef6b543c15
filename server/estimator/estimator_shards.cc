// Estimator::ShardSummary: the message a map shard sends every other shard (docs/SCALING.md).
#include <set>

#include "core/factors/linear_container_factor.h"
#include "core/marginals/separator_summary.h"
#include "server/estimator/estimator.h"

namespace slamd::server {

core::Result<std::optional<ShardSummaryMessage>> Estimator::ShardSummary(std::int64_t utime) {
  const ShardMap& shards = params_.shards;
  if (!shards.sharded()) return core::FailedPrecondition("shard summary: not a shard");
  FinishUpdate();  // the estimate of every variable
  // The summaries received (excluded: each shard's own factors are counted once, by it).
  std::vector<core::FactorPtr> received;
  std::set<int> received_slots;
  for (auto it = applied_.lower_bound({ShardSummarySpec::kIdentity, 0, 0, 0});
       it != applied_.end() && std::get<0>(it->first) == ShardSummarySpec::kIdentity; ++it) {
    const int slot = numbers_.slot(it->second);
    if (slot < 0) continue;
    received.push_back(isam_->factor_slots()[slot]);
    received_slots.insert(slot);
  }
  // The boundary (shard_boundary.h), grown as factors were applied, and by the factors in the
  // graph (a state restored from an older snapshot, the summaries of removed variables); then
  // the keys only the received summaries name.
  shard_boundary_.KeepOnly(isam_->linearization_point());
  const auto& slots = isam_->factor_slots();
  for (std::size_t i = 0; i < slots.size(); ++i) {
    if (slots[i]) shard_boundary_.Grow(*slots[i], received_slots.contains(static_cast<int>(i)));
  }
  const std::set<core::Key>& boundary = shard_boundary_.keys();
  if (boundary.empty()) return std::optional<ShardSummaryMessage>();
  std::set<core::Key> beyond;
  for (const core::FactorPtr& f : received) {
    for (core::Key k : f->keys()) {
      if (!boundary.contains(k)) beyond.insert(k);
    }
  }
  core::KeyVector keys(boundary.begin(), boundary.end());
  keys.insert(keys.end(), beyond.begin(), beyond.end());
  core::Result<core::FactorPtr> summary = core::SeparatorSummary(
      *isam_, *marginals_, keys, received, {.kept_keys = static_cast<int>(boundary.size())});
  if (!summary.ok()) return summary.status();
  if (!*summary) return std::optional<ShardSummaryMessage>();
  const auto& c = static_cast<const core::LinearContainerFactor&>(**summary);
  ShardSummaryMessage m{.utime = utime, .from_shard = shards.self};
  for (core::Key k : c.keys()) {
    m.poses.emplace_back(registry_.Name(core::KeyRobot(k)), core::KeyIndex(k));
  }
  m.x0 = c.linearization_point();
  m.A = c.A();
  m.b = c.b();
  return std::optional<ShardSummaryMessage>(std::move(m));
}

}  // namespace slamd::server
