// Recovery: rebuilds the estimator of a data directory after a restart or a crash, before slamd
// listens. Steps:
//   1. the newest valid snapshot (server/journal/snapshot_file.h; corrupt newer ones are
//      skipped and reported) -> Estimator::Restore, at its journal position; none: empty;
//   2. the journal's segments (server/journal/journal_segments.h) in order: message records after
//   the snapshot's
//      last_message_sequence are decoded (same validation as live intake) and collected; each
//      update-boundary record after the snapshot's offset hands the collected messages up to its
//      last_message_sequence to ONE Estimator::Process call, each refinement record repeats a
//      Refine of the same round count, so the updates of the original run happen again in the
//      same order;
//   3. a torn tail (a crash mid-write) is reported with its offset and truncated; corruption in
//      the middle stops recovery with the reader's error (offsets, reason) unless `salvage`, as
//      does a journal whose oldest kept segment starts after the snapshot's position (the
//      segments deleted as covered by a snapshot that is no longer there or valid);
//   4. messages journaled after the last boundary (accepted, never processed) are returned in
//      `pending` for the daemon to queue before anything new.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/isam/isam2_params.h"
#include "server/estimator/estimator.h"
#include "server/estimator/estimator_params.h"
#include "server/journal/journal_segments.h"

namespace slamd::server {

struct RecoveryResult {
  std::unique_ptr<Estimator> estimator;
  std::vector<Inbound> pending;        // accepted, not yet processed (journal order)
  std::int64_t last_sequence = 0;      // last message sequence in the journal
  std::string snapshot_path;           // "" when none was loaded
  std::int64_t snapshot_sequence = 0;  // the snapshot's last_message_sequence
  std::int64_t snapshot_journal_offset = 0;  // and its journal_offset
  std::int64_t replayed_messages = 0;
  std::int64_t replayed_updates = 0;  // Process calls (boundaries)
  std::int64_t replayed_refinements = 0;
  std::int64_t replayed_rebuild_swaps = 0;
  std::int64_t replayed_removals = 0;  // lifelong-window removals
  std::int64_t torn_tail_offset = -1;  // where the journal was cut (-1: it was whole)
  std::string torn_tail_reason;
  std::int64_t salvaged_bytes = 0;  // skipped under salvage
  std::vector<std::string> notes;   // what a log should say (skipped snapshots, ...)
  std::vector<JournalSegment> segments;  // as read (for Journal::Open); empty: no journal
  double seconds = 0.0;
};

// `data_dir` must exist. Errors name the file and offset (DataLoss for corruption, IoError).
core::Result<RecoveryResult> Recover(const std::string& data_dir, const EstimatorParams& params,
                                     const core::Isam2Params& isam2, bool salvage);

}  // namespace slamd::server
