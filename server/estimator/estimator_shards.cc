// Estimator::ShardSummary: the message a map shard sends every other shard (docs/SCALING.md).
#include <algorithm>
#include <iterator>
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
  // The shared map's landmarks its own factors name: those another shard holds too join the
  // boundary, and the list goes with the summary (so the others find the ones they share).
  shard_boundary_.KeepOnly(isam_->linearization_point());
  const auto& slots = isam_->factor_slots();
  std::set<std::uint64_t> own_landmarks;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    if (!slots[i]) continue;
    const bool from_summary = received_slots.contains(static_cast<int>(i));
    shard_boundary_.Grow(*slots[i], from_summary);
    for (core::Key k : slots[i]->keys()) {
      if (!from_summary && core::KeySymbol(k) == kMapLandmarkSymbol) {
        own_landmarks.insert(core::KeyIndex(k));
      }
    }
  }
  shard_boundary_.GrowShared(own_landmarks);
  // At most what a summary may carry (the lowest ids): the others are not found shared.
  auto listed = own_landmarks.begin();
  std::advance(listed, std::min<std::size_t>(own_landmarks.size(), kMaxSummaryMapLandmarks));
  ShardSummaryMessage m{
      .utime = utime, .from_shard = shards.self, .map_landmarks = {own_landmarks.begin(), listed}};
  const auto landmarks_only = [&]() -> std::optional<ShardSummaryMessage> {
    if (m.map_landmarks.empty()) return std::nullopt;
    return std::move(m);
  };
  const std::set<core::Key>& boundary = shard_boundary_.keys();
  if (boundary.empty()) return landmarks_only();
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
  if (!*summary) return landmarks_only();
  const auto& c = static_cast<const core::LinearContainerFactor&>(**summary);
  for (core::Key k : c.keys()) {
    if (core::KeySymbol(k) == kMapLandmarkSymbol) {
      m.keys.push_back({"", KeyKind::kMapLandmark, core::KeyIndex(k)});
    } else {
      m.keys.push_back({registry_.Name(core::KeyRobot(k)), KeyKind::kPose, core::KeyIndex(k)});
    }
  }
  m.x0 = c.linearization_point();
  m.A = c.A();
  m.b = c.b();
  return std::optional<ShardSummaryMessage>(std::move(m));
}

}  // namespace slamd::server
