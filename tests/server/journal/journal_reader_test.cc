#include "server/journal/journal_reader.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "server/journal/journal_format.h"
#include "server/journal/journal_writer.h"
#include "server/journal/read_journal.h"
#include "slamd_proto/journal.pb.h"
#include "tests/testing/files.h"

namespace slamd::server {
namespace {

using journal::JournalRecord;

JournalRecord LandmarkMessage(int64_t seq, std::size_t payload_bytes, std::mt19937* rng) {
  JournalRecord r;
  auto* m = r.mutable_message();
  m->set_sequence(seq);
  m->set_channel("SLAMD_LANDMARK");
  m->set_message_type("landmark_t");
  std::string bytes(payload_bytes, '\0');
  for (auto& c : bytes) c = static_cast<char>((*rng)());
  m->set_lcm_payload(bytes);
  return r;
}

// A journal of n records written by JournalWriter: its bytes, records and frame offsets
// (offsets has n + 1 entries, the last being the file size).
struct Fixture {
  std::string bytes;
  std::vector<JournalRecord> records;
  std::vector<int64_t> offsets;
};

class JournalReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/journal_reader_XXXXXX";
    ASSERT_NE(::mkdtemp(dir_.data()), nullptr);
    path_ = dir_ + "/journal.jnl";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  Fixture Make(int n, uint32_t seed) {
    std::mt19937 rng(seed);
    Fixture f;
    const std::string path = dir_ + "/source.jnl";
    std::filesystem::remove(path);
    auto w = JournalWriter::Open(path, {});
    EXPECT_TRUE(w.ok());
    f.offsets.push_back((*w)->offset());
    for (int i = 0; i < n; ++i) {
      JournalRecord r;
      if (i % 4 == 3) {
        r.mutable_boundary()->set_update_sequence(i / 4 + 1);
        r.mutable_boundary()->set_last_message_sequence(i);
        r.mutable_boundary()->set_message_count(3);
      } else {
        r = LandmarkMessage(i + 1, 1 + rng() % 1500, &rng);
      }
      EXPECT_TRUE((*w)->Append(r).ok());
      f.records.push_back(r);
      f.offsets.push_back((*w)->offset());
    }
    EXPECT_TRUE((*w)->Close().ok());
    f.bytes = testing::ReadFileBytes(path);
    return f;
  }

  std::string dir_, path_;
};

// The first k records of c are the first k of f (c may hold more).
void ExpectPrefix(const JournalContents& c, const Fixture& f, std::size_t k) {
  ASSERT_GE(c.records.size(), k);
  for (std::size_t i = 0; i < k; ++i) {
    ASSERT_EQ(c.records[i].SerializeAsString(), f.records[i].SerializeAsString()) << i;
    ASSERT_EQ(c.offsets[i], f.offsets[i]) << i;
  }
}

TEST_F(JournalReaderTest, StreamsRecordsWithOffsetsAndEndsClean) {
  const Fixture f = Make(12, 1);
  testing::WriteFileBytes(path_, f.bytes);
  auto reader = JournalReader::Open(path_, {});
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  JournalRecord r;
  int64_t offset = -1;
  for (int i = 0; i < 12; ++i) {
    ASSERT_EQ((*reader)->Next(&r, &offset), JournalReadState::kRecord);
    EXPECT_EQ(offset, f.offsets[i]);
    EXPECT_EQ(r.SerializeAsString(), f.records[i].SerializeAsString());
  }
  EXPECT_EQ((*reader)->Next(&r, &offset), JournalReadState::kCleanEnd);
  EXPECT_EQ((*reader)->Next(&r, &offset), JournalReadState::kCleanEnd);  // sticky
  EXPECT_EQ((*reader)->valid_end_offset(), static_cast<int64_t>(f.bytes.size()));
  EXPECT_EQ((*reader)->records_read(), 12);
}

TEST_F(JournalReaderTest, EmptyJournalIsClean) {
  testing::WriteFileBytes(path_, internal::EncodeJournalHeader());
  auto c = ReadJournal(path_);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
  EXPECT_TRUE(c->records.empty());
}

// Crash mid-write at random offsets: exactly the records entirely before the cut come back, the
// rest is a torn tail at the first incomplete record; after truncation the writer appends and a
// re-read is clean.
TEST_F(JournalReaderTest, TornTailAtRandomCutsThenTruncateAndAppend) {
  const Fixture f = Make(40, 2);
  std::mt19937 rng(20260);
  std::vector<int64_t> cuts = {0, 5, 15, 16, 17, 23, 24};
  for (int i = 0; i < 250; ++i) cuts.push_back(rng() % (f.bytes.size() + 1));
  for (int64_t k = 0; k <= 40; ++k) cuts.push_back(f.offsets[k]);  // exact boundaries
  for (const int64_t cut : cuts) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    testing::WriteFileBytes(path_, f.bytes.substr(0, cut));
    auto c = ReadJournal(path_);
    ASSERT_TRUE(c.ok()) << c.status().ToString();
    std::size_t k = 0;
    while (k < f.records.size() && f.offsets[k + 1] <= cut) ++k;
    ASSERT_EQ(c->records.size(), k);
    ExpectPrefix(*c, f, k);
    int64_t append_at = 0;
    if (cut < kJournalHeaderSize) {
      EXPECT_EQ(c->end, JournalReadState::kTornTail);
      EXPECT_EQ(c->torn_tail_offset, 0);
    } else if (cut == f.offsets[k]) {
      EXPECT_EQ(c->end, JournalReadState::kCleanEnd);
      append_at = cut;
    } else {
      EXPECT_EQ(c->end, JournalReadState::kTornTail);
      EXPECT_EQ(c->torn_tail_offset, f.offsets[k]);
      EXPECT_FALSE(c->end_reason.empty());
      append_at = f.offsets[k];
    }
    if (c->end == JournalReadState::kTornTail) {
      ASSERT_TRUE(TruncateTornTail(path_, c->torn_tail_offset).ok());
    }
    auto w = JournalWriter::Open(path_, {});
    ASSERT_TRUE(w.ok()) << w.status().ToString();
    EXPECT_EQ((*w)->offset(), std::max<int64_t>(append_at, kJournalHeaderSize));
    JournalRecord extra;
    extra.mutable_boundary()->set_update_sequence(999);
    ASSERT_TRUE((*w)->Append(extra).ok());
    ASSERT_TRUE((*w)->Close().ok());
    auto again = ReadJournal(path_);
    ASSERT_TRUE(again.ok()) << again.status().ToString();
    EXPECT_EQ(again->end, JournalReadState::kCleanEnd);
    ExpectPrefix(*again, f, k);
    ASSERT_EQ(again->records.size(), k + 1);
    EXPECT_EQ(again->records[k].boundary().update_sequence(), 999);
  }
}

TEST_F(JournalReaderTest, BitFlipInTheMiddleIsAnErrorNamingTheOffsetAndSalvageSkipsIt) {
  const Fixture f = Make(30, 3);
  std::mt19937 rng(77);
  for (int trial = 0; trial < 150; ++trial) {
    const std::size_t victim = rng() % (f.records.size() - 1);  // not the last
    const int64_t frame = f.offsets[victim + 1] - f.offsets[victim];
    const int64_t byte = f.offsets[victim] + static_cast<int64_t>(rng() % frame);
    const int bit = static_cast<int>(rng() % 8);
    SCOPED_TRACE("record " + std::to_string(victim) + " byte " + std::to_string(byte) + " bit " +
                 std::to_string(bit));
    std::string bytes = f.bytes;
    bytes[byte] = static_cast<char>(bytes[byte] ^ (1 << bit));
    testing::WriteFileBytes(path_, bytes);

    auto c = ReadJournal(path_);
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.status().code(), core::StatusCode::kDataLoss);
    EXPECT_NE(
        c.status().message().find("corrupt record at offset " + std::to_string(f.offsets[victim])),
        std::string::npos)
        << c.status().message();
    EXPECT_NE(c.status().message().find(path_), std::string::npos);

    auto s = ReadJournal(path_, {.salvage = true});
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    EXPECT_EQ(s->end, JournalReadState::kCleanEnd);
    ASSERT_EQ(s->records.size(), f.records.size() - 1);
    for (std::size_t i = 0, j = 0; i < f.records.size(); ++i) {
      if (i == victim) continue;
      EXPECT_EQ(s->records[j].SerializeAsString(), f.records[i].SerializeAsString());
      EXPECT_EQ(s->offsets[j], f.offsets[i]);
      ++j;
    }
    ASSERT_EQ(s->skipped.size(), 1u);
    EXPECT_EQ(s->skipped[0].offset, f.offsets[victim]);
    EXPECT_EQ(s->skipped[0].length, frame);
    EXPECT_EQ(s->skipped_bytes, frame);
  }
}

TEST_F(JournalReaderTest, BitFlipInTheLastRecordIsATornTail) {
  const Fixture f = Make(10, 4);
  std::mt19937 rng(78);
  const int64_t start = f.offsets[9];
  for (int trial = 0; trial < 60; ++trial) {
    std::string bytes = f.bytes;
    const int64_t byte = start + static_cast<int64_t>(rng() % (bytes.size() - start));
    bytes[byte] = static_cast<char>(bytes[byte] ^ (1 << (rng() % 8)));
    testing::WriteFileBytes(path_, bytes);
    auto c = ReadJournal(path_);
    ASSERT_TRUE(c.ok()) << c.status().ToString();
    EXPECT_EQ(c->end, JournalReadState::kTornTail);
    EXPECT_EQ(c->torn_tail_offset, start);
    ASSERT_EQ(c->records.size(), 9u);
    ExpectPrefix(*c, f, 9);
  }
}

TEST_F(JournalReaderTest, SalvageSkipsSeveralRegionsIncludingInsertedGarbage) {
  const Fixture f = Make(20, 5);
  std::string bytes = f.bytes;
  bytes[f.offsets[12] + 9] ^= 0x10;     // damage record 12's payload
  bytes[f.offsets[3] + 2] ^= 0x01;      // and record 3's length
  const std::string garbage(37, '\0');  // and a hole of zeros before record 7
  bytes.insert(f.offsets[7], garbage);
  testing::WriteFileBytes(path_, bytes);

  auto c = ReadJournal(path_);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find("offset " + std::to_string(f.offsets[3])), std::string::npos);

  auto s = ReadJournal(path_, {.salvage = true});
  ASSERT_TRUE(s.ok());
  ASSERT_EQ(s->skipped.size(), 3u);
  EXPECT_EQ(s->skipped[0].offset, f.offsets[3]);
  EXPECT_EQ(s->skipped[1].offset, f.offsets[7]);
  EXPECT_EQ(s->skipped[1].length, 37);
  EXPECT_EQ(s->skipped[2].offset, f.offsets[12] + 37);
  EXPECT_EQ(s->records.size(), 18u);
  EXPECT_EQ(s->end, JournalReadState::kCleanEnd);
}

TEST_F(JournalReaderTest, TrailingZerosOrGarbageAreATornTail) {
  const Fixture f = Make(6, 6);
  for (const std::string& tail :
       {std::string(4096, '\0'), std::string("\x05\x00\x00\x00xx", 6), std::string(3, '\xff')}) {
    testing::WriteFileBytes(path_, f.bytes + tail);
    auto c = ReadJournal(path_);
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(c->end, JournalReadState::kTornTail);
    EXPECT_EQ(c->torn_tail_offset, static_cast<int64_t>(f.bytes.size()));
    EXPECT_EQ(c->records.size(), 6u);
  }
}

TEST_F(JournalReaderTest, ChecksumValidButUnparseableOrKindlessRecordIsInvalid) {
  const Fixture f = Make(3, 7);
  std::string frame;
  internal::AppendJournalFrame(std::string("\x18\x01", 2), &frame);  // field 3: no kind
  testing::WriteFileBytes(path_, f.bytes + frame);
  auto c = ReadJournal(path_);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->end, JournalReadState::kTornTail);
  EXPECT_NE(c->end_reason.find("no kind"), std::string::npos) << c->end_reason;
  frame.clear();
  internal::AppendJournalFrame(std::string("\x0a\x7f", 2), &frame);  // truncated submessage
  testing::WriteFileBytes(path_, f.bytes + frame);
  c = ReadJournal(path_);
  ASSERT_TRUE(c.ok());
  EXPECT_NE(c->end_reason.find("does not parse"), std::string::npos) << c->end_reason;
}

TEST_F(JournalReaderTest, BadMagicOrVersionIsAClearErrorEvenWithSalvage) {
  const Fixture f = Make(3, 8);
  std::string bytes = f.bytes;
  bytes[7] = 'X';
  testing::WriteFileBytes(path_, bytes);
  for (bool salvage : {false, true}) {
    auto c = ReadJournal(path_, {.salvage = salvage});
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.status().code(), core::StatusCode::kDataLoss);
    EXPECT_NE(c.status().message().find("at offset 0: bad magic"), std::string::npos)
        << c.status().message();
  }
  bytes = f.bytes;
  bytes[8] = 2;
  testing::WriteFileBytes(path_, bytes);
  auto c = ReadJournal(path_);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.status().message().find("unsupported version 2"), std::string::npos);
  testing::WriteFileBytes(path_, "NOTJNL");  // short and not a header prefix
  c = ReadJournal(path_);
  EXPECT_EQ(c.status().code(), core::StatusCode::kDataLoss);
  c = ReadJournal(dir_ + "/missing.jnl");
  EXPECT_EQ(c.status().code(), core::StatusCode::kNotFound);
}

TEST_F(JournalReaderTest, TruncateTornTailRejectsOffsetsOutsideTheFile) {
  testing::WriteFileBytes(path_, internal::EncodeJournalHeader());
  EXPECT_EQ(TruncateTornTail(path_, 17).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(TruncateTornTail(path_, -1).code(), core::StatusCode::kInvalidArgument);
  EXPECT_EQ(TruncateTornTail(dir_ + "/missing", 0).code(), core::StatusCode::kIoError);
  EXPECT_TRUE(TruncateTornTail(path_, 16).ok());
}

}  // namespace
}  // namespace slamd::server
