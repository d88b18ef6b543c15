#include "server/estimator/recovery.h"

#include "core/base/timing.h"
#include "server/estimator/journal_replay.h"
#include "server/journal/journal_reader.h"
#include "server/journal/journal_segments.h"
#include "server/journal/snapshot_file.h"
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
  JournalReplay replay(out.estimator.get(), position.last_message_sequence);
  journal::JournalRecord record;
  std::int64_t offset = 0;
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
    // A boundary or refinement the snapshot already includes (messages check their sequence).
    if (!record.has_message() && offset < position.journal_offset) continue;
    SLAMD_RETURN_IF_ERROR(replay.Apply(record, At(path, offset), salvage));
  }
  out.last_sequence = replay.last_sequence();
  out.replayed_messages = replay.messages();
  out.replayed_updates = replay.updates();
  out.replayed_refinements = replay.refinements();
  out.replayed_rebuild_swaps = replay.rebuild_swaps();
  out.replayed_removals = replay.removals();
  for (std::string& note : replay.notes()) out.notes.push_back(std::move(note));
  out.salvaged_bytes = reader.skipped_bytes();
  if (out.torn_tail_offset >= 0) {
    SLAMD_RETURN_IF_ERROR(
        TruncateTornTail(reader.torn_tail_path(), reader.torn_tail_file_offset()));
  }
  out.segments = reader.segments();
  if (out.torn_tail_offset >= 0) out.segments.back().end = out.torn_tail_offset;
  out.estimator->SetReplaying(false);
  out.pending = replay.TakePending();
  out.seconds = timer.Seconds();
  return out;
}

}  // namespace slamd::server
