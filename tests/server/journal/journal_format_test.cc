#include "server/journal/journal_format.h"

#include <gtest/gtest.h>

#include <string>

#include "server/journal/crc32c.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server::internal {
namespace {

TEST(JournalFormatTest, HeaderBytesAreMagicVersionReserved) {
  const std::string h = EncodeJournalHeader();
  ASSERT_EQ(h.size(), 16u);
  EXPECT_EQ(h.substr(0, 8), "SLAMDJNL");
  EXPECT_EQ(h.substr(8, 8), std::string("\x01\x00\x00\x00\x00\x00\x00\x00", 8));
  EXPECT_EQ(CheckJournalHeader(h.data()), "");
}

TEST(JournalFormatTest, CheckHeaderNamesTheProblem) {
  std::string h = EncodeJournalHeader();
  h[3] = 'X';
  EXPECT_NE(CheckJournalHeader(h.data()).find("bad magic"), std::string::npos);
  h = EncodeJournalHeader();
  h[8] = 2;
  EXPECT_NE(CheckJournalHeader(h.data()).find("unsupported version 2"), std::string::npos);
}

TEST(JournalFormatTest, LittleEndianHelpers) {
  char b[8];
  PutLe32(0x11223344u, b);
  EXPECT_EQ(std::string(b, 4), "\x44\x33\x22\x11");
  EXPECT_EQ(GetLe32(b), 0x11223344u);
  PutLe64(0x0102030405060708ull, b);
  EXPECT_EQ(std::string(b, 8), "\x08\x07\x06\x05\x04\x03\x02\x01");
  EXPECT_EQ(GetLe64(b), 0x0102030405060708ull);
}

TEST(JournalFormatTest, FrameIsLengthMaskedCrcOfLengthAndPayloadThenPayload) {
  const std::string payload("abc\x00xyz", 7);
  std::string frame;
  AppendJournalFrame(payload, &frame);
  ASSERT_EQ(frame.size(), 8 + payload.size());
  EXPECT_EQ(frame.substr(0, 4), std::string("\x07\x00\x00\x00", 4));
  // Reference: CRC of the concatenated bytes, computed in one go.
  const uint32_t expected = MaskCrc32c(Crc32c(frame.substr(0, 4) + payload));
  EXPECT_EQ(GetLe32(frame.data() + 4), expected);
  EXPECT_EQ(frame.substr(8), payload);
}

// Masking + covering the length: an all-zero region never parses as a record.
TEST(JournalFormatTest, ZeroBytesNeverFormAValidFrame) {
  const char zeros[8] = {};
  EXPECT_NE(JournalRecordChecksum(zeros, zeros, 0), 0u);
}

// The scan for the next valid record probes only positions whose first payload byte could start
// a record: every kind's does (a kind added to JournalRecord must be added there too).
TEST(JournalFormatTest, EveryRecordKindStartsPlausibly) {
  const google::protobuf::Descriptor* d = journal::JournalRecord::GetDescriptor();
  for (int f = 0; f < d->field_count(); ++f) {
    journal::JournalRecord r;
    r.GetReflection()->MutableMessage(&r, d->field(f));
    const std::string bytes = r.SerializeAsString();
    ASSERT_FALSE(bytes.empty()) << d->field(f)->name();
    EXPECT_TRUE(PlausibleRecordStart(bytes[0])) << d->field(f)->name();
  }
  int plausible = 0;
  for (int b = 0; b < 256; ++b) plausible += PlausibleRecordStart(static_cast<char>(b)) ? 1 : 0;
  EXPECT_EQ(plausible, 5);
}

}  // namespace
}  // namespace slamd::server::internal
