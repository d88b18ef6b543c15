#include "server/journal/read_journal.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>

#include "server/journal/journal_writer.h"

namespace slamd::server {
namespace {

TEST(ReadJournalTest, CollectsRecordsOffsetsAndEndState) {
  std::string dir = ::testing::TempDir() + "/read_journal_XXXXXX";
  ASSERT_NE(::mkdtemp(dir.data()), nullptr);
  const std::string path = dir + "/j.jnl";
  std::vector<int64_t> starts;
  {
    auto w = JournalWriter::Open(path, {});
    ASSERT_TRUE(w.ok());
    for (int i = 1; i <= 3; ++i) {
      journal::JournalRecord r;
      r.mutable_message()->set_sequence(i);
      r.mutable_message()->set_channel("C");
      starts.push_back((*w)->offset());
      ASSERT_TRUE((*w)->Append(r).ok());
    }
    ASSERT_TRUE((*w)->Close().ok());
  }
  auto c = ReadJournal(path);
  ASSERT_TRUE(c.ok()) << c.status().ToString();
  ASSERT_EQ(c->records.size(), 3u);
  EXPECT_EQ(c->offsets, starts);
  EXPECT_EQ(c->records[2].message().sequence(), 3);
  EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
  EXPECT_EQ(c->torn_tail_offset, -1);
  EXPECT_EQ(c->valid_end_offset, c->file_size);
  EXPECT_EQ(c->skipped_bytes, 0);
  // Cut one byte off the last record: torn tail at its start, two records.
  std::filesystem::resize_file(path, c->file_size - 1);
  c = ReadJournal(path);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->end, JournalReadState::kTornTail);
  EXPECT_EQ(c->torn_tail_offset, starts[2]);
  EXPECT_EQ(c->valid_end_offset, starts[2]);
  EXPECT_EQ(c->records.size(), 2u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace slamd::server
