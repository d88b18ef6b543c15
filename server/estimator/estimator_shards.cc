// Estimator::ShardSummary: the message a map shard sends a neighbour (docs/SCALING.md).
#include <algorithm>
#include <array>
#include <set>

#include "core/factors/linear_container_factor.h"
#include "core/marginals/separator_summary.h"
#include "server/estimator/estimator.h"

namespace slamd::server {

core::Result<std::optional<ShardSummaryMessage>> Estimator::ShardSummary(
    const std::string& neighbour, std::int64_t utime) {
  const ShardMap& shards = params_.shards;
  if (!shards.sharded() || neighbour == shards.self) {
    return core::InvalidArgument("shard summary for '" + neighbour + "': not a neighbour of '" +
                                 shards.self + "'");
  }
  FinishUpdate();  // the estimate of every variable
  // Which registered robots the neighbour owns.
  std::array<bool, 256> theirs{};
  for (std::uint8_t id : registry_.ids())
    theirs[id] = shards.OwnerOf(registry_.Name(id)) == neighbour;
  // Both ends of every factor on one of their poses (their summary included, so that what it is
  // taken out of has its keys).
  std::set<core::Key> shared;
  for (const core::FactorPtr& f : isam_->factor_slots()) {
    if (!f) continue;
    const bool touches = std::any_of(f->keys().begin(), f->keys().end(), [&](core::Key k) {
      return core::KeySymbol(k) == 'x' && theirs[core::KeyRobot(k)];
    });
    if (!touches) continue;
    for (core::Key k : f->keys()) {
      if (core::KeySymbol(k) == 'x') shared.insert(k);
    }
  }
  if (shared.empty()) return std::optional<ShardSummaryMessage>();
  std::vector<core::FactorPtr> excluded;
  const auto it = applied_.find({ShardSummarySpec::kIdentity, ShardIdentity(neighbour), 0, 0});
  if (it != applied_.end() && solver_index_[it->second] >= 0) {
    excluded.push_back(isam_->factor_slots()[solver_index_[it->second]]);
  }
  const core::KeyVector keys(shared.begin(), shared.end());
  core::Result<core::FactorPtr> summary =
      core::SeparatorSummary(*isam_, *marginals_, keys, excluded);
  if (!summary.ok()) return summary.status();
  if (!*summary) return std::optional<ShardSummaryMessage>();
  const auto& c = static_cast<const core::LinearContainerFactor&>(**summary);
  ShardSummaryMessage m{.utime = utime, .from_shard = shards.self, .to_shard = neighbour};
  for (core::Key k : keys) {
    m.poses.emplace_back(registry_.Name(core::KeyRobot(k)), core::KeyIndex(k));
  }
  m.x0 = c.linearization_point();
  m.A = c.A();
  m.b = c.b();
  return std::optional<ShardSummaryMessage>(std::move(m));
}

}  // namespace slamd::server
