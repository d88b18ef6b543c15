// The snapshot writer's thread: each state handed over is written, in order, and the one handed
// over last before the writer ends is written too (no snapshot lost at shutdown); the room a
// snapshot needs is made before it is written.
#include "server/daemon/snapshot_writer.h"

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <string>
#include <vector>

#include "server/journal/journal_segments.h"
#include "server/journal/snapshot_file.h"
#include "tests/testing/files.h"

namespace slamd::server {
namespace {

TEST(SnapshotWriterTest, WritesEveryStateHandedOverAndTheLastBeforeItEnds) {
  testing::TempDir dir("slamd_snapshot_writer_");
  ServerParams::Journal params;
  params.keep_snapshots = 3;
  params.delete_covered_segments = false;  // no journal here
  {
    SnapshotWriter writer(dir.path(), params, nullptr, spdlog::default_logger(), 0, nullptr, 0);
    for (std::int64_t i = 1; i <= 3; ++i) {
      auto state = std::make_shared<EstimatorState>();
      state->update_sequence = 10 * i;
      // Write waits for the previous snapshot; the third is still being written when the
      // writer goes.
      writer.Write(std::move(state), {.last_message_sequence = i, .journal_offset = 100 * i},
                   10 * i, 1'000'000 * i, 0);
    }
  }
  const core::Result<std::vector<SnapshotFileInfo>> files = ListSnapshots(dir.path());
  ASSERT_TRUE(files.ok()) << files.status().ToString();
  ASSERT_EQ(files.value().size(), 3u);
  for (const SnapshotFileInfo& file : files.value()) {
    int64_t offset = 0;
    const core::Result<std::string> bytes = ReadSnapshotFile(file.path, &offset);
    ASSERT_TRUE(bytes.ok()) << bytes.status().ToString();
    JournalPosition position;
    const core::Result<EstimatorState> state = DecodeState(bytes.value(), &position);
    ASSERT_TRUE(state.ok()) << state.status().ToString();
    EXPECT_EQ(position.journal_offset, offset);
    EXPECT_EQ(state.value().update_sequence, offset / 10);
    EXPECT_EQ(position.last_message_sequence, offset / 100);
  }
}

// With keep_snapshots 2 the oldest snapshot and the segments only it needed are gone before the
// next is written, so the directory never holds three. Seen through a write that fails (its
// temporary's name taken by a directory): what is left is the room made for it.
TEST(SnapshotWriterTest, TheOldestSnapshotAndItsSegmentsGoBeforeTheNextIsWritten) {
  testing::TempDir dir("slamd_snapshot_room_");
  core::Result<std::unique_ptr<Journal>> opened = Journal::Open(
      dir.path(), {.writer = {.sync_policy = SyncPolicy::kNever}, .segment_bytes = 4096}, {}, 0);
  ASSERT_TRUE(opened.ok()) << opened.status().ToString();
  Journal& journal = *opened.value();
  const std::vector<std::uint8_t> payload(500, 7);
  // Appends 20 messages (2-3 segments) and returns the position after them.
  auto append = [&]() -> JournalPosition {
    for (int i = 0; i < 20; ++i) {
      EXPECT_TRUE(journal.AppendMessage("SLAMD_ODOMETRY", "odometry_t", payload, 1).ok());
    }
    EXPECT_TRUE(journal.Sync().ok());
    return {.last_message_sequence = journal.last_sequence(), .journal_offset = journal.offset()};
  };
  auto segment_bases = [&] {
    std::vector<std::int64_t> bases;
    for (const JournalSegment& s : ListJournalSegments(dir.path()).value()) bases.push_back(s.base);
    return bases;
  };
  ServerParams::Journal params;  // keep_snapshots 2, delete_covered_segments
  SnapshotWriter writer(dir.path(), params, &journal, spdlog::default_logger(), 0, nullptr, 0);
  auto write = [&](const JournalPosition& at, std::int64_t sequence) {
    writer.Write(std::make_shared<EstimatorState>(), at, sequence, sequence, 0);
    writer.Join();
  };
  const JournalPosition first = append();
  write(first, 1);
  const JournalPosition second = append();
  write(second, 2);
  ASSERT_EQ(ListSnapshots(dir.path()).value().size(), 2u);
  // Kept from the first snapshot on: a segment starts before the second.
  ASSERT_LT(segment_bases().front(), second.journal_offset);

  const JournalPosition third = append();
  const std::string blocked = dir.File("." + SnapshotFileName(third.journal_offset) + ".tmp");
  std::filesystem::create_directory(blocked);
  write(third, 3);
  const std::vector<SnapshotFileInfo> left = ListSnapshots(dir.path()).value();
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left.front().sequence, second.journal_offset);
  // The journal from the second snapshot on, no segment wholly before it.
  const std::vector<std::int64_t> bases = segment_bases();
  ASSERT_GE(bases.size(), 2u);
  EXPECT_GT(bases[1], second.journal_offset);

  // Once the write can go through, two snapshots again.
  std::filesystem::remove(blocked);
  write(third, 4);
  const std::vector<SnapshotFileInfo> now = ListSnapshots(dir.path()).value();
  ASSERT_EQ(now.size(), 2u);
  EXPECT_EQ(now.front().sequence, third.journal_offset);
  EXPECT_EQ(now.back().sequence, second.journal_offset);
}

// A snapshot is due once the journal grew snapshot_every_bytes since the last one (or since the
// snapshot recovery loaded), whatever the update count and the time.
TEST(SnapshotWriterTest, DueOnceTheJournalGrewTheConfiguredBytes) {
  testing::TempDir dir("slamd_snapshot_bytes_");
  ServerParams::Journal params;
  params.snapshot_every_updates = 0;
  params.snapshot_every_s = 0;
  params.snapshot_every_bytes = 1000;
  params.delete_covered_segments = false;  // no journal here
  const JournalPosition recovered{.last_message_sequence = 40, .journal_offset = 5000};
  SnapshotWriter writer(dir.path(), params, nullptr, spdlog::default_logger(), 7, &recovered, 0);
  EXPECT_FALSE(writer.Due(7, 1'000'000, 9000)) << "the recovered state has not moved on";
  EXPECT_FALSE(writer.Due(8, 1'000'000, 5999));
  EXPECT_TRUE(writer.Due(8, 1'000'000, 6000));
  writer.Write(std::make_shared<EstimatorState>(),
               {.last_message_sequence = 50, .journal_offset = 6100}, 8, 1'000'000, 0);
  writer.Join();
  // Long after (the 5% gate open), counted from the snapshot just written.
  EXPECT_FALSE(writer.Due(9, 100'000'000, 7099));
  EXPECT_TRUE(writer.Due(9, 100'000'000, 7100));
  params.snapshot_every_bytes = 0;
  SnapshotWriter never(dir.path(), params, nullptr, spdlog::default_logger(), 7, &recovered, 0);
  EXPECT_FALSE(never.Due(8, 100'000'000, 1'000'000'000));
}

}  // namespace
}  // namespace slamd::server
