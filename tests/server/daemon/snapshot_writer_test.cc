// The snapshot writer's thread: each state handed over is written, in order, and the one handed
// over last before the writer ends is written too (no snapshot lost at shutdown).
#include "server/daemon/snapshot_writer.h"

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

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

}  // namespace
}  // namespace slamd::server
