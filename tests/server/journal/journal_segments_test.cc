// The journal as segment files (server/journal/journal_segments.h, journal.h): rolling to a new
// segment, reading them back as one journal with global offsets, deleting covered segments, a
// missing or damaged segment, the legacy single file.
#include "server/journal/journal_segments.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "server/journal/journal.h"
#include "server/journal/journal_writer.h"
#include "server/journal/read_journal.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

namespace fs = std::filesystem;

constexpr std::int64_t kSegmentBytes = 4096;

class JournalSegmentsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/segments_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<Journal> Open(std::vector<JournalSegment> segments = {},
                                std::int64_t last_sequence = 0) {
    core::Result<std::unique_ptr<Journal>> j = Journal::Open(
        dir_, {.writer = {.sync_policy = SyncPolicy::kNever}, .segment_bytes = kSegmentBytes},
        std::move(segments), last_sequence);
    EXPECT_TRUE(j.ok()) << j.status().ToString();
    return j.ok() ? std::move(j).value() : nullptr;
  }
  // `n` messages of 200 bytes, an update boundary after every 5th.
  static void Append(Journal* journal, int n) {
    const std::vector<std::uint8_t> payload(200, 3);
    for (int i = 0; i < n; ++i) {
      const core::Result<std::int64_t> seq =
          journal->AppendMessage("SLAMD_ODOMETRY", "odometry_t", payload, 1);
      ASSERT_TRUE(seq.ok()) << seq.status().ToString();
      if (seq.value() % 5 == 0)
        ASSERT_TRUE(journal->AppendBoundary(seq.value(), seq.value(), 5).ok());
    }
    ASSERT_TRUE(journal->Sync().ok());
  }
  std::vector<JournalSegment> Listed() const { return ListJournalSegments(dir_).value(); }

  std::string dir_;
};

// Past segment_bytes the journal starts a new file whose base is where the last one ended; read
// back, the segments are one journal: every record once, in order, at increasing global offsets.
TEST_F(JournalSegmentsTest, SegmentsReadBackAsOneJournal) {
  auto journal = Open();
  Append(journal.get(), 100);  // ~25 kB: several segments
  const std::vector<JournalSegment> listed = Listed();
  ASSERT_GE(listed.size(), 4u);
  EXPECT_EQ(journal->segments(), static_cast<int>(listed.size()));
  EXPECT_EQ(listed.front().base, 0);
  std::int64_t disk = 0;
  for (size_t k = 0; k < listed.size(); ++k) {
    const auto size = static_cast<std::int64_t>(fs::file_size(listed[k].path));
    disk += size;
    if (k + 1 < listed.size()) {
      EXPECT_EQ(listed[k + 1].base, listed[k].base + size);
      EXPECT_LT(size, kSegmentBytes + 400);  // rolled at the first record past the limit
    }
  }
  EXPECT_EQ(journal->disk_bytes(), disk);

  const JournalContents c = ReadJournal(dir_).value();
  EXPECT_EQ(c.end, JournalReadState::kCleanEnd);
  EXPECT_EQ(c.valid_end_offset, journal->offset());
  EXPECT_EQ(c.file_size, journal->offset());
  EXPECT_EQ(c.disk_bytes, disk);
  std::int64_t sequence = 0;
  for (size_t i = 0; i < c.records.size(); ++i) {
    if (i > 0) EXPECT_GT(c.offsets[i], c.offsets[i - 1]);
    if (c.records[i].has_message()) EXPECT_EQ(c.records[i].message().sequence(), ++sequence);
  }
  EXPECT_EQ(sequence, 100);
  EXPECT_EQ(c.records.size(), 120u);
  // Each segment's last message, as recovery hands them to Journal::Open.
  ASSERT_EQ(c.segments.size(), listed.size());
  for (size_t k = 0; k + 1 < c.segments.size(); ++k) {
    EXPECT_EQ(c.segments[k].end, c.segments[k + 1].base);
    EXPECT_LT(c.segments[k].last_message_sequence, c.segments[k + 1].last_message_sequence);
  }
  EXPECT_EQ(c.segments.back().last_message_sequence, 100);
}

// Reopened with what a reader found, the journal appends to its newest segment and numbers on.
TEST_F(JournalSegmentsTest, ReopenedJournalAppendsToTheNewestSegment) {
  Append(Open().get(), 40);
  const std::int64_t segments = static_cast<std::int64_t>(Listed().size());
  const JournalContents before = ReadJournal(dir_).value();
  auto journal = Open(before.segments, 40);
  EXPECT_EQ(journal->offset(), before.valid_end_offset);
  Append(journal.get(), 40);
  EXPECT_GT(static_cast<std::int64_t>(Listed().size()), segments);
  const JournalContents after = ReadJournal(dir_).value();
  std::int64_t sequence = 0;
  for (const journal::JournalRecord& r : after.records) {
    if (r.has_message()) EXPECT_EQ(r.message().sequence(), ++sequence);
  }
  EXPECT_EQ(sequence, 80);
}

// DeleteCovered removes the oldest segments that end before the position and whose messages are
// all covered; never one holding a later message, never the newest.
TEST_F(JournalSegmentsTest, DeleteCoveredRemovesOnlyCoveredSegments) {
  auto journal = Open();
  Append(journal.get(), 100);
  const JournalContents c = ReadJournal(dir_).value();
  const std::vector<JournalSegment>& s = c.segments;
  ASSERT_GE(s.size(), 4u);
  // A position inside segment 2: segments 0 and 1 are covered.
  const std::int64_t offset = s[2].base + 100;
  // Messages covered only up to segment 0's last: segment 1 holds later ones and stays.
  EXPECT_EQ(journal->DeleteCovered(s[0].last_message_sequence, offset).value(), 1);
  EXPECT_FALSE(fs::exists(s[0].path));
  EXPECT_TRUE(fs::exists(s[1].path));
  EXPECT_EQ(journal->DeleteCovered(s[1].last_message_sequence, offset).value(), 1);
  EXPECT_FALSE(fs::exists(s[1].path));
  EXPECT_EQ(journal->DeleteCovered(1000, offset).value(), 0);  // segment 2 ends after offset
  // Everything covered: all but the newest.
  EXPECT_EQ(journal->DeleteCovered(1000, journal->offset()).value(),
            static_cast<int>(s.size()) - 3);
  ASSERT_EQ(Listed().size(), 1u);
  EXPECT_EQ(journal->segments(), 1);
  EXPECT_EQ(journal->disk_bytes(), static_cast<std::int64_t>(fs::file_size(Listed()[0].path)));

  // What is left reads back from its base, and appending carries on.
  Append(journal.get(), 10);
  const JournalContents left = ReadJournal(dir_).value();
  EXPECT_EQ(left.end, JournalReadState::kCleanEnd);
  EXPECT_EQ(left.offsets.front(), s.back().base + 16);
  std::int64_t last = 0;
  for (const journal::JournalRecord& r : left.records) {
    if (r.has_message()) last = r.message().sequence();
  }
  EXPECT_EQ(last, 110);
}

// A segment missing in the middle is a gap, not an end: DataLoss naming it; salvage skips it.
TEST_F(JournalSegmentsTest, MissingSegmentIsCorruptionUnlessSalvaged) {
  Append(Open().get(), 100);
  const std::vector<JournalSegment> listed = Listed();
  fs::remove(listed[1].path);
  const core::Result<JournalContents> c = ReadJournal(dir_);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(c.status().message().find(listed[2].path), std::string::npos) << c.status().message();
  EXPECT_NE(c.status().message().find("missing"), std::string::npos);
  const JournalContents s = ReadJournal(dir_, {.salvage = true}).value();
  ASSERT_EQ(s.skipped.size(), 1u);
  EXPECT_EQ(s.skipped[0].offset, listed[1].base);
  EXPECT_EQ(s.skipped[0].length, listed[2].base - listed[1].base);
  EXPECT_EQ(s.end, JournalReadState::kCleanEnd);
}

// A damaged record at the end of a closed segment is not a torn tail (the segment was synced
// before the next began): corruption. At the end of the newest it is the torn tail, in global
// offsets, with the file and the offset in it to cut.
TEST_F(JournalSegmentsTest, TornTailOnlyInTheNewestSegment) {
  Append(Open().get(), 100);
  const std::vector<JournalSegment> listed = Listed();
  const auto cut = [](const std::string& path) { fs::resize_file(path, fs::file_size(path) - 3); };
  cut(listed.back().path);
  auto reader = SegmentedJournalReader::Open(dir_, {}).value();
  journal::JournalRecord record;
  while (reader->Next(&record) == JournalReadState::kRecord) {
  }
  ASSERT_EQ(reader->state(), JournalReadState::kTornTail);
  EXPECT_EQ(reader->torn_tail_path(), listed.back().path);
  EXPECT_EQ(reader->torn_tail_offset(), listed.back().base + reader->torn_tail_file_offset());
  EXPECT_GT(reader->torn_tail_file_offset(), 16);

  cut(listed[1].path);
  const core::Result<JournalContents> c = ReadJournal(dir_);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(c.status().message().find(listed[1].path), std::string::npos) << c.status().message();
  const JournalContents s = ReadJournal(dir_, {.salvage = true}).value();
  EXPECT_EQ(s.end, JournalReadState::kTornTail);
  EXPECT_GE(s.skipped.size(), 1u);
}

// A data directory from before segments: its journal.slamdj is the segment of base 0, read as
// such and renamed when the journal opens; both at once is refused.
TEST_F(JournalSegmentsTest, LegacyJournalIsTheFirstSegment) {
  {
    auto writer = JournalWriter::Open(LegacyJournalPath(dir_), {}).value();
    journal::JournalRecord r;
    journal::InboundMessage* m = r.mutable_message();
    m->set_sequence(1);
    m->set_channel("SLAMD_ODOMETRY");
    m->set_message_type("odometry_t");
    ASSERT_TRUE(writer->Append(r).ok());
    ASSERT_TRUE(writer->Close().ok());
  }
  fs::copy_file(LegacyJournalPath(dir_), JournalSegmentPath(dir_, 0));
  EXPECT_EQ(ListJournalSegments(dir_).status().code(), core::StatusCode::kDataLoss);
  fs::remove(JournalSegmentPath(dir_, 0));

  const JournalContents c = ReadJournal(dir_).value();
  ASSERT_EQ(c.records.size(), 1u);
  ASSERT_EQ(c.segments.size(), 1u);
  EXPECT_EQ(c.segments[0].path, LegacyJournalPath(dir_));
  auto journal = Open(c.segments, 1);
  EXPECT_FALSE(fs::exists(LegacyJournalPath(dir_)));
  EXPECT_TRUE(fs::exists(JournalSegmentPath(dir_, 0)));
  Append(journal.get(), 1);
  EXPECT_EQ(ReadJournal(dir_).value().records.size(), 2u);
}

TEST_F(JournalSegmentsTest, NamesAndOptions) {
  EXPECT_EQ(JournalSegmentName(4096), "journal-00000000000000004096.slamdj");
  fs::create_directories(dir_ + "/sub");
  for (const char* name : {"journal-1.slamdj", "journal-0000000000000000000x.slamdj", "x.slamdj",
                           "journal-00000000000000004096.slamdj.tmp"}) {
    std::ofstream(dir_ + "/" + name) << "x";
  }
  std::ofstream(JournalSegmentPath(dir_, 4096)) << "x";
  const std::vector<JournalSegment> listed = Listed();
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].base, 4096);
  EXPECT_EQ(SegmentedJournalReader::Open(dir_ + "/sub", {}).status().code(),
            core::StatusCode::kNotFound);
  const core::Status bad = JournalOptions{.segment_bytes = 100}.Validate();
  EXPECT_EQ(bad.message(), "JournalOptions::segment_bytes = 100; violates >= 4096");
}

}  // namespace
}  // namespace slamd::server
