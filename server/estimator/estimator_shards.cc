// Estimator::ShardSummary: the message a map shard sends every other shard (docs/SCALING.md).
#include <algorithm>
#include <array>
#include <set>

#include "core/factors/linear_container_factor.h"
#include "core/marginals/separator_summary.h"
#include "server/estimator/estimator.h"

namespace slamd::server {

core::Result<std::optional<ShardSummaryMessage>> Estimator::ShardSummary(std::int64_t utime) {
  const ShardMap& shards = params_.shards;
  if (!shards.sharded()) return core::FailedPrecondition("shard summary: not a shard");
  FinishUpdate();  // the estimate of every variable
  std::array<bool, 256> foreign{};
  for (std::uint8_t id : registry_.ids()) foreign[id] = !shards.Owns(registry_.Name(id));
  const auto is_foreign = [&](core::Key k) {
    return core::KeySymbol(k) == 'x' && foreign[core::KeyRobot(k)];
  };
  // The summaries received (excluded: each shard's own factors are counted once, by it).
  std::vector<core::FactorPtr> received;
  std::set<int> received_slots;
  for (auto it = applied_.lower_bound({ShardSummarySpec::kIdentity, 0, 0, 0});
       it != applied_.end() && std::get<0>(it->first) == ShardSummarySpec::kIdentity; ++it) {
    const int slot = solver_index_[it->second];
    if (slot < 0) continue;
    received.push_back(isam_->factor_slots()[slot]);
    received_slots.insert(slot);
  }
  // The boundary: both ends of its own factors on another shard's poses, and its own poses in
  // what the others sent; and what it was before, still in the graph (a pose whose closure was
  // retracted stays: the other shards may hold it only through this summary, and dropping it
  // would leave it there with no factor). Then the keys only the received summaries name.
  std::set<core::Key>& boundary = shard_boundary_;
  std::erase_if(boundary, [&](core::Key k) { return !isam_->linearization_point().Contains(k); });
  std::set<core::Key> beyond;
  const auto& slots = isam_->factor_slots();
  for (std::size_t i = 0; i < slots.size(); ++i) {
    const core::FactorPtr& f = slots[i];
    if (!f || received_slots.contains(static_cast<int>(i))) continue;
    if (std::none_of(f->keys().begin(), f->keys().end(), is_foreign)) continue;
    for (core::Key k : f->keys()) {
      if (core::KeySymbol(k) == 'x') boundary.insert(k);
    }
  }
  for (const core::FactorPtr& f : received) {
    for (core::Key k : f->keys()) {
      if (!is_foreign(k)) boundary.insert(k);
    }
  }
  if (boundary.empty()) return std::optional<ShardSummaryMessage>();
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
