#include "server/estimator/journal_replay.h"

#include <algorithm>
#include <iterator>
#include <limits>

#include "server/messages/inbound_codec.h"
#include "server/snapshot/state_codec.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

core::Status JournalReplay::Apply(const journal::JournalRecord& record, const std::string& where,
                                  bool salvage) {
  if (record.has_message()) {
    const journal::InboundMessage& m = record.message();
    if (m.sequence() <= last_sequence_) return core::Status::Ok();  // already included
    if (m.sequence() != last_sequence_ + 1 && !salvage) {
      return core::DataLoss(where + ": message sequence " + std::to_string(m.sequence()) +
                            " after " + std::to_string(last_sequence_) +
                            " (a gap: records are missing)");
    }
    last_sequence_ = m.sequence();
    const auto* data = reinterpret_cast<const std::uint8_t*>(m.lcm_payload().data());
    core::Result<Inbound> in = DecodeInbound(m.message_type(), {data, m.lcm_payload().size()});
    if (!in.ok()) {
      if (!salvage) return core::DataLoss(where + ": " + in.status().message());
      notes_.push_back(where + ": skipped: " + in.status().message());
      return core::Status::Ok();
    }
    in.value().journal_sequence = m.sequence();
    collected_.push_back(std::move(in).value());
    ++messages_;
  } else if (record.has_boundary()) {
    const std::int64_t last = record.boundary().last_message_sequence();
    size_t n = 0;
    while (n < collected_.size() && collected_[n].journal_sequence <= last) ++n;
    std::vector<Inbound> batch(
        std::make_move_iterator(collected_.begin()),
        std::make_move_iterator(collected_.begin() + static_cast<std::ptrdiff_t>(n)));
    collected_.erase(collected_.begin(), collected_.begin() + static_cast<std::ptrdiff_t>(n));
    estimator_->Process(std::move(batch));
    ++updates_;
  } else if (record.has_refinement()) {
    estimator_->Refine(std::numeric_limits<double>::infinity(), record.refinement().rounds());
    ++refinements_;
  } else if (record.has_removal()) {
    const journal::Removal& removal = record.removal();
    NodeRemovalRecord what{.keys = {removal.keys().begin(), removal.keys().end()},
                           .roots = {removal.roots().begin(), removal.roots().end()}};
    // No values in a journal written before they were kept: the replay's θ.
    core::Status removed = DecodeValues(removal.at(), "removal", &what.at);
    for (const snapshot::PoseAlias& a : removal.aliases()) {
      core::Result<PoseAlias> alias = DecodeAlias(a);
      if (!alias.ok()) removed = alias.status();
      if (alias.ok()) what.aliases.emplace_back(a.pose(), std::move(alias).value());
    }
    std::sort(what.aliases.begin(), what.aliases.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    if (removed.ok()) removed = estimator_->RemoveVariables(what);
    if (!removed.ok()) notes_.push_back(where + ": " + removed.message());
    if (removed.ok()) ++removals_;
  } else if (record.has_rebuild_swap()) {
    // None in flight when the rebuild started before the snapshot: then there is none to swap.
    const auto& rounds = record.rebuild_swap().catch_up_rounds();
    const core::Result<bool> swapped =
        estimator_->FinishRebuild({rounds.data(), static_cast<size_t>(rounds.size())});
    if (!swapped.ok()) notes_.push_back(where + ": " + swapped.status().message());
    if (swapped.ok() && swapped.value()) ++rebuild_swaps_;
  }
  return core::Status::Ok();
}

std::vector<Inbound> JournalReplay::TakePending() { return std::move(collected_); }

}  // namespace slamd::server
