// On-disk format of the slamd write-ahead journal (version 1). All integers little-endian.
//
//   file   = header record*
//   header = magic "SLAMDJNL" (8 bytes) | uint32 version = 1 | uint32 reserved = 0     (16 bytes)
//   record = uint32 length | uint32 masked CRC32C | payload (length bytes)
//
// length is the payload size in bytes, 1..kMaxRecordPayload (a larger or zero length is
// corruption). The checksum is MaskCrc32c(CRC32C(the 4 length bytes, then the payload)): covering
// the length means a flipped length bit is caught, and masking means a run of zero bytes (what a
// crash can leave in an extended file) never parses as a record. The payload is a serialised
// slamd.journal.JournalRecord (msgs/proto/journal.proto) with its `kind` set.
// A record is *valid* at offset p when its 8 header bytes and whole payload lie inside the file,
// the length is in range, the checksum matches and the payload parses with `kind` set.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace slamd::journal {
class JournalRecord;
}

namespace slamd::server {

inline constexpr char kJournalMagic[8] = {'S', 'L', 'A', 'M', 'D', 'J', 'N', 'L'};
inline constexpr uint32_t kJournalVersion = 1;
inline constexpr int64_t kJournalHeaderSize = 16;               // [bytes]
inline constexpr int64_t kJournalRecordHeaderSize = 8;          // length + checksum [bytes]
// A map shard summary on ~470 shared 2D poses is this large (dense: (3k)² doubles for k poses).
inline constexpr uint32_t kJournalMaxRecordPayload = 16u << 20;  // 16 MiB [bytes]

namespace internal {

inline void PutLe32(uint32_t v, char* out) {
  for (int i = 0; i < 4; ++i) out[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
}
inline void PutLe64(uint64_t v, char* out) {
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
}
inline uint32_t GetLe32(const char* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t{static_cast<unsigned char>(p[i])} << (8 * i);
  return v;
}
inline uint64_t GetLe64(const char* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= uint64_t{static_cast<unsigned char>(p[i])} << (8 * i);
  return v;
}

// The 16 header bytes of a version-1 journal.
std::string EncodeJournalHeader();

// "" when the 16 bytes at `header` are a valid version-1 header, else what is wrong
// ("bad magic ...", "unsupported version 7 (this build reads 1)").
std::string CheckJournalHeader(const char* header);

// Whether `first` can be a record payload's first byte: the tag of one of JournalRecord's kinds
// (msgs/proto/journal.proto: fields 1..5, all messages, so (field << 3) | 2). Scanning for the
// next valid record probes only such positions: a plausible length alone passes 1 byte in 256
// (lengths up to 16 MiB), and each probe checks up to 16 MiB.
inline bool PlausibleRecordStart(char first) {
  const auto b = static_cast<unsigned char>(first);
  return (b & 7u) == 2u && (b >> 3) >= 1u && (b >> 3) <= 5u;
}

// Masked CRC32C over the 4 little-endian length bytes followed by the payload.
uint32_t JournalRecordChecksum(const char* length_le, const char* payload, std::size_t n);

// Appends the framed record (length, checksum, payload) to *out.
void AppendJournalFrame(std::string_view payload, std::string* out);

// Checks the record whose 8 header bytes (length, checksum) are at `header` and whose payload of
// `length` bytes (already in range) is at `payload`: the checksum, the parse, the kind. "" when
// valid (*record filled), else what is wrong ("checksum mismatch (stored 0x..., computed ...)").
std::string DecodeJournalPayload(const char* header, const char* payload, uint32_t length,
                                 journal::JournalRecord* record);

}  // namespace internal
}  // namespace slamd::server
