// `slamctl journal bench DATASET`: durability figures of slamd on a dataset:
//   1. journal overhead: the dataset's messages appended through server::Journal as the daemon
//      does in lock-step (one update boundary + Commit per dataset step), per sync policy
//      (never / interval / always) [µs per message, µs per update];
//   2. a session: the daemon driven in-process (InProcessBus, no threads, refinement off) on a
//      data directory, one update per step; a snapshot (ExportState + EncodeState +
//      WriteSnapshotFile) written by hand `--tail` steps before the end, and one of the full
//      state timed at the end [s, bytes];
//   3. recovery (server/estimator/recovery.h Recover) of journal prefixes of 1k, 5k, 10k, ...
//      messages (cut after an update boundary, no snapshot), of the whole journal, and of the
//      snapshot + the tail [s].
// Everything is written under --dir (default: a fresh directory in $TMPDIR, removed afterwards
// unless --keep). Numbers depend on the disk (fdatasync) and the machine's load.
#pragma once

#include <CLI/CLI.hpp>

namespace slamd::clients {

// Adds `bench` under the `journal` subcommand.
void RegisterJournalBench(CLI::App* journal);

}  // namespace slamd::clients
