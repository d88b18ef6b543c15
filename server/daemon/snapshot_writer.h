// SnapshotWriter: the daemon's snapshots. The estimator thread exports its state when one is due
// (journal.snapshot_every_updates / _s) and hands it over; the writer's thread, slamd-snapshot,
// encodes it and writes it atomically (server/journal/snapshot_file.h), keeping
// journal.keep_snapshots. At most 5% of the time goes to snapshots: the next is due no sooner
// than 20x the last one's export + write time, as on a large map both grow.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "server/config/server_params.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"

namespace spdlog {
class logger;
}  // namespace spdlog

namespace slamd::server {

class SnapshotWriter {
 public:
  // `last_sequence`: the update sequence of the state recovered at start (no snapshot is due
  // before the estimate moves on from it). `now_us`: steady clock.
  SnapshotWriter(std::string data_dir, const ServerParams::Journal& params,
                 std::shared_ptr<spdlog::logger> log, std::int64_t last_sequence,
                 std::int64_t now_us);
  ~SnapshotWriter();  // waits for the snapshot being written
  SnapshotWriter(const SnapshotWriter&) = delete;
  SnapshotWriter& operator=(const SnapshotWriter&) = delete;

  // A snapshot of update `sequence` is due at `now_us` and none is being written.
  bool Due(std::int64_t sequence, std::int64_t now_us) const;
  // Writes `state` (exported in export_us) of update `sequence` at `position` on the writer's
  // thread.
  void Write(std::shared_ptr<const EstimatorState> state, const JournalPosition& position,
             std::int64_t sequence, std::int64_t now_us, std::int64_t export_us);
  // Waits for the snapshot being written, if any.
  void Join();

 private:
  std::string data_dir_;
  ServerParams::Journal params_;
  std::shared_ptr<spdlog::logger> log_;
  std::int64_t last_sequence_;  // of the last snapshot written (or recovered)
  std::int64_t last_us_;        // when it was due
  std::thread thread_;
  std::atomic<bool> busy_{false};
  std::atomic<std::int64_t> cost_us_{0};  // the last snapshot's export + write time
};

}  // namespace slamd::server
