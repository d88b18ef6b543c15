// Snapshot files: the estimator state (opaque bytes here: serialised factors, values,
// linearisation point and journal position are the caller's business) written atomically into a
// data directory, with a checksum so a torn or corrupt file is detected, never loaded.
//
// Format (little-endian), file name "snapshot-<sequence, 20 digits>.snp":
//   magic "SLAMDSNP" (8) | uint32 version = 1 | uint32 masked CRC32C of the bytes from offset 16
//   to the end | int64 sequence | uint64 payload length | payload
//
// Atomicity: WriteSnapshotFile writes a hidden temporary file ".snapshot-<seq>.snp.tmp" in the
// same directory, fsyncs it, renames it to its final name and fsyncs the directory. A crash at
// any point leaves either the complete new file or none (plus possibly a temporary, which
// ListSnapshots ignores and the next successful write removes). Older snapshots are removed only
// after the new one is durable, keeping the newest `keep`.
// Assumes one writer per directory (the daemon's snapshot thread) and increasing sequences.
// Not thread-safe against concurrent writers of the same directory; readers are fine.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/status.h"

namespace slamd::server {

struct SnapshotFileOptions {
  // Snapshots kept after a successful write, the new one included [count]. Default 2, >= 1.
  int keep = 2;

  core::Status Validate() const;  // "SnapshotFileOptions::keep = 0; violates >= 1"
};

struct SnapshotFileInfo {
  std::string path;      // dir + "/" + file name
  int64_t sequence = 0;  // from the file name
};

// "snapshot-00000000000000000042.snp" for sequence 42 (zero-padded: names sort by sequence).
std::string SnapshotFileName(int64_t sequence);

// Atomically writes `bytes` as the snapshot `sequence` in the existing directory `dir` and
// prunes older ones; returns the new file's path. sequence >= 0. On failure (IoError naming the
// path and cause) the temporary is removed and existing snapshots are untouched.
core::Result<std::string> WriteSnapshotFile(const std::string& dir, int64_t sequence,
                                            std::string_view bytes,
                                            const SnapshotFileOptions& options = {});

// Removes the snapshots of `dir` beyond the newest `keep` (>= 1; InvalidArgument otherwise) and
// any temporaries; the snapshot writer makes room so before a write (server/daemon).
core::Status PruneSnapshots(const std::string& dir, int keep);

// The snapshot files in `dir` (by name only; contents not checked), newest (highest sequence)
// first. Temporaries and other files are ignored. IoError / NotFound if dir cannot be listed.
core::Result<std::vector<SnapshotFileInfo>> ListSnapshots(const std::string& dir);

// The payload of a snapshot file, after checking magic, version, length and checksum. DataLoss
// naming the path and what was wrong for a torn or corrupt file; NotFound / IoError otherwise.
// *sequence (if not null) gets the sequence stored in the header.
core::Result<std::string> ReadSnapshotFile(const std::string& path, int64_t* sequence = nullptr);

struct LoadedSnapshot {
  SnapshotFileInfo info;
  std::string bytes;
  std::vector<std::string> skipped;  // errors of newer snapshots that were corrupt
};

// The newest snapshot in `dir` that reads back valid, skipping (and listing) corrupt newer
// ones. NotFound when there is no valid snapshot (a fresh start: replay the whole journal).
core::Result<LoadedSnapshot> LoadNewestSnapshot(const std::string& dir);

}  // namespace slamd::server
