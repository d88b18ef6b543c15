// JournalReplay: applies journal records to an estimator in journal order, so the updates of the
// original run happen again: messages are decoded (the validation of live intake) and collected;
// an update boundary hands the collected ones up to its last_message_sequence to ONE
// Estimator::Process; a refinement repeats a Refine of the same round count; removals and swaps
// of rebuilt solvers are repeated as recorded. Recovery (recovery.h) feeds it a data directory's
// journal; a standby (server/replication) feeds it the replicated journal as the stream brings it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "server/estimator/estimator.h"

namespace slamd::journal {
class JournalRecord;
}

namespace slamd::server {

class JournalReplay {
 public:
  // `estimator` is not owned; messages up to `last_sequence` are already in it (a snapshot's).
  JournalReplay(Estimator* estimator, std::int64_t last_sequence)
      : estimator_(estimator), last_sequence_(last_sequence) {}

  // Applies one record; `where` names it in errors and notes ("journal /d at offset 96").
  // DataLoss for a message that does not decode or leaves a gap in the sequence (under
  // `salvage` the message is skipped and noted instead). A message already included (sequence
  // <= last_sequence()) is skipped. Problems that do not stop the replay (a removal or swap the
  // estimator refuses) go to notes().
  core::Status Apply(const journal::JournalRecord& record, const std::string& where, bool salvage);

  // Messages applied but not yet processed (no boundary after them yet), in order; moved out.
  std::vector<Inbound> TakePending();
  std::int64_t last_sequence() const { return last_sequence_; }
  std::int64_t messages() const { return messages_; }  // collected
  std::int64_t updates() const { return updates_; }    // Process calls (boundaries)
  std::int64_t refinements() const { return refinements_; }
  std::int64_t rebuild_swaps() const { return rebuild_swaps_; }
  std::int64_t removals() const { return removals_; }
  std::vector<std::string>& notes() { return notes_; }

 private:
  Estimator* estimator_;
  std::int64_t last_sequence_ = 0;
  std::vector<Inbound> collected_;
  std::int64_t messages_ = 0, updates_ = 0, refinements_ = 0, rebuild_swaps_ = 0, removals_ = 0;
  std::vector<std::string> notes_;
};

}  // namespace slamd::server
