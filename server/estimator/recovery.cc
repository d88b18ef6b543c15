#include "server/estimator/recovery.h"

#include "core/base/timing.h"
#include "server/journal/journal_reader.h"
#include "server/journal/journal_segments.h"
#include "server/journal/snapshot_file.h"
#include "server/messages/inbound_codec.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

std::string At(const std::string& path, std::int64_t offset) {
  return path + " at offset " + std::to_string(offset);
}

}  // namespace

core::Result<RecoveryResult> Recover(const std::string& data_dir, const EstimatorParams& params,
                                     const core::Isam2Params& isam2, bool salvage) {
  core::Stopwatch timer;
  RecoveryResult out;

  // 1. The newest valid snapshot.
  JournalPosition position;
  core::Result<LoadedSnapshot> snapshot = LoadNewestSnapshot(data_dir);
  if (snapshot.ok()) {
    for (const std::string& s : snapshot.value().skipped) out.notes.push_back("skipped " + s);
    core::Result<EstimatorState> state = DecodeState(snapshot.value().bytes, &position);
    if (!state.ok()) {
      return core::DataLoss(snapshot.value().info.path + ": " + state.status().message());
    }
    core::Result<std::unique_ptr<Estimator>> restored =
        Estimator::Restore(params, isam2, state.value());
    if (!restored.ok()) {
      return core::DataLoss(snapshot.value().info.path + ": " + restored.status().message());
    }
    out.estimator = std::move(restored).value();
    out.snapshot_path = snapshot.value().info.path;
    out.snapshot_sequence = position.last_message_sequence;
    out.snapshot_journal_offset = position.journal_offset;
    out.last_sequence = position.last_message_sequence;
  } else if (snapshot.status().code() == core::StatusCode::kNotFound) {
    core::Result<std::unique_ptr<Estimator>> made = Estimator::Create(params, isam2);
    if (!made.ok()) return made.status();
    out.estimator = std::move(made).value();
  } else {
    return snapshot.status();
  }

  // 2. The journal.
  core::Result<std::unique_ptr<SegmentedJournalReader>> opened =
      SegmentedJournalReader::Open(data_dir, {.salvage = salvage});
  if (opened.status().code() == core::StatusCode::kNotFound) {
    out.seconds = timer.Seconds();
    return out;
  }
  if (!opened.ok()) return opened.status();
  SegmentedJournalReader& reader = *opened.value();
  const std::string path = "journal " + data_dir;  // errors name global offsets in it
  if (reader.first_offset() > position.journal_offset) {
    // Segments are deleted only once a snapshot covers them; that snapshot is gone.
    const std::string s = out.snapshot_path.empty()
                              ? "no valid snapshot"
                              : "the snapshot " + out.snapshot_path + " reaches only offset " +
                                    std::to_string(position.journal_offset);
    return core::DataLoss("journal " + data_dir + " starts at offset " +
                          std::to_string(reader.first_offset()) +
                          " (older segments were deleted as covered by snapshots), but " + s);
  }
  // Rebuilds started in the replay catch up as their swap records say, not as threads run.
  out.estimator->SetReplaying(true);
  journal::JournalRecord record;
  std::int64_t offset = 0;
  std::vector<Inbound> collected;
  for (;;) {
    const JournalReadState state = reader.Next(&record, &offset);
    if (state == JournalReadState::kCleanEnd) break;
    if (state == JournalReadState::kTornTail) {
      out.torn_tail_offset = reader.torn_tail_offset();
      out.torn_tail_reason = reader.end_reason();
      break;
    }
    if (state == JournalReadState::kError) {
      return core::Status(
          reader.error().code(),
          reader.error().message() + (salvage ? "" : " (slamd --salvage skips corrupt records)"));
    }
    if (record.has_message()) {
      const journal::InboundMessage& m = record.message();
      if (m.sequence() <= position.last_message_sequence) continue;  // in the snapshot
      if (m.sequence() != out.last_sequence + 1 && !salvage) {
        return core::DataLoss(At(path, offset) + ": message sequence " +
                              std::to_string(m.sequence()) + " after " +
                              std::to_string(out.last_sequence) + " (a gap: records are missing)");
      }
      out.last_sequence = m.sequence();
      const auto* data = reinterpret_cast<const std::uint8_t*>(m.lcm_payload().data());
      core::Result<Inbound> in = DecodeInbound(m.message_type(), {data, m.lcm_payload().size()});
      if (!in.ok()) {
        if (salvage) {
          out.notes.push_back(At(path, offset) + ": skipped: " + in.status().message());
          continue;
        }
        return core::DataLoss(At(path, offset) + ": " + in.status().message());
      }
      in.value().journal_sequence = m.sequence();
      collected.push_back(std::move(in).value());
      ++out.replayed_messages;
    } else if (offset < position.journal_offset) {
      continue;  // a boundary or refinement the snapshot already includes
    } else if (record.has_boundary()) {
      const std::int64_t last = record.boundary().last_message_sequence();
      std::vector<Inbound> batch;
      size_t n = 0;
      while (n < collected.size() && collected[n].journal_sequence <= last) ++n;
      batch.assign(std::make_move_iterator(collected.begin()),
                   std::make_move_iterator(collected.begin() + static_cast<std::ptrdiff_t>(n)));
      collected.erase(collected.begin(), collected.begin() + static_cast<std::ptrdiff_t>(n));
      out.estimator->Process(std::move(batch));
      ++out.replayed_updates;
    } else if (record.has_refinement()) {
      out.estimator->Refine(std::numeric_limits<double>::infinity(), record.refinement().rounds());
      ++out.replayed_refinements;
    } else if (record.has_removal()) {
      const auto& keys = record.removal().keys();
      const core::Status removed =
          out.estimator->RemoveVariables({keys.data(), static_cast<size_t>(keys.size())});
      if (!removed.ok()) out.notes.push_back(At(path, offset) + ": " + removed.message());
      if (removed.ok()) ++out.replayed_removals;
    } else if (record.has_rebuild_swap()) {
      // None in flight when the rebuild started before the snapshot: then there is none to swap.
      const auto& rounds = record.rebuild_swap().catch_up_rounds();
      const core::Result<bool> swapped =
          out.estimator->FinishRebuild({rounds.data(), static_cast<size_t>(rounds.size())});
      if (!swapped.ok()) out.notes.push_back(At(path, offset) + ": " + swapped.status().message());
      if (swapped.ok() && swapped.value()) ++out.replayed_rebuild_swaps;
    }
  }
  out.salvaged_bytes = reader.skipped_bytes();
  if (out.torn_tail_offset >= 0) {
    SLAMD_RETURN_IF_ERROR(
        TruncateTornTail(reader.torn_tail_path(), reader.torn_tail_file_offset()));
  }
  out.segments = reader.segments();
  if (out.torn_tail_offset >= 0) out.segments.back().end = out.torn_tail_offset;
  out.estimator->SetReplaying(false);
  out.pending = std::move(collected);
  out.seconds = timer.Seconds();
  return out;
}

}  // namespace slamd::server
