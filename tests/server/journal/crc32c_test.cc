#include "server/journal/crc32c.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace slamd::server {
namespace {

// Independent reference: the CRC bit by bit straight from the definition (reflected polynomial,
// init and final xor 0xFFFFFFFF), no tables.
uint32_t BitwiseCrc32c(const unsigned char* p, std::size_t n) {
  uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ 0x82F63B78u : c >> 1;
  }
  return ~c;
}

TEST(Crc32cTest, CheckValue) { EXPECT_EQ(Crc32c("123456789"), 0xE3069283u); }

TEST(Crc32cTest, EmptyIsZero) { EXPECT_EQ(Crc32c("", 0), 0u); }

// RFC 3720 (iSCSI) appendix B.4 test vectors.
TEST(Crc32cTest, Rfc3720Vectors) {
  std::vector<unsigned char> buf(32, 0x00);
  EXPECT_EQ(Crc32c(buf.data(), buf.size()), 0x8A9136AAu);
  buf.assign(32, 0xFF);
  EXPECT_EQ(Crc32c(buf.data(), buf.size()), 0x62A8AB43u);
  for (int i = 0; i < 32; ++i) buf[i] = static_cast<unsigned char>(i);
  EXPECT_EQ(Crc32c(buf.data(), buf.size()), 0x46DD794Eu);
  for (int i = 0; i < 32; ++i) buf[i] = static_cast<unsigned char>(31 - i);
  EXPECT_EQ(Crc32c(buf.data(), buf.size()), 0x113FDB5Cu);
  const unsigned char iscsi_read[48] = {0x01, 0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                        0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00,
                                        0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00,
                                        0x00, 0x18, 0x28, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                        0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  EXPECT_EQ(Crc32c(iscsi_read, sizeof(iscsi_read)), 0xD9963A56u);
}

// Slicing-by-8 against the bitwise definition for every alignment and many lengths.
TEST(Crc32cTest, MatchesBitwiseReferenceAtAnyAlignmentAndLength) {
  std::mt19937 rng(7);
  std::vector<unsigned char> buf(4096 + 16);
  for (auto& b : buf) b = static_cast<unsigned char>(rng());
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t start = rng() % 16;
    const std::size_t n = trial < 100 ? static_cast<std::size_t>(trial) : rng() % 4096;
    ASSERT_EQ(Crc32c(buf.data() + start, n), BitwiseCrc32c(buf.data() + start, n))
        << "start " << start << " n " << n;
  }
}

TEST(Crc32cTest, ExtendEqualsCrcOfConcatenation) {
  const std::string a = "hello, ", b = "write-ahead journal";
  EXPECT_EQ(Crc32cExtend(Crc32c(a), b.data(), b.size()), Crc32c(a + b));
  EXPECT_EQ(Crc32cExtend(Crc32c(a), "", 0), Crc32c(a));
}

TEST(Crc32cTest, MaskRoundTripsAndChangesTheValue) {
  std::mt19937 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const uint32_t c = static_cast<uint32_t>(rng());
    EXPECT_EQ(UnmaskCrc32c(MaskCrc32c(c)), c);
  }
  const uint32_t c = Crc32c("foo");
  EXPECT_NE(MaskCrc32c(c), c);
  EXPECT_NE(MaskCrc32c(MaskCrc32c(c)), MaskCrc32c(c));
}

}  // namespace
}  // namespace slamd::server
