#include "server/journal/journal_format.h"

#include <cstdio>
#include <cstring>

#include "server/journal/crc32c.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server::internal {

std::string EncodeJournalHeader() {
  std::string h(kJournalHeaderSize, '\0');
  std::memcpy(h.data(), kJournalMagic, sizeof(kJournalMagic));
  PutLe32(kJournalVersion, h.data() + 8);
  PutLe32(0, h.data() + 12);  // reserved
  return h;
}

std::string CheckJournalHeader(const char* header) {
  if (std::memcmp(header, kJournalMagic, sizeof(kJournalMagic)) != 0) {
    return "bad magic (not a slamd journal: expected \"SLAMDJNL\")";
  }
  const uint32_t version = GetLe32(header + 8);
  if (version != kJournalVersion) {
    return "unsupported version " + std::to_string(version) + " (this build reads " +
           std::to_string(kJournalVersion) + ")";
  }
  return "";
}

uint32_t JournalRecordChecksum(const char* length_le, const char* payload, std::size_t n) {
  return MaskCrc32c(Crc32cExtend(Crc32c(length_le, 4), payload, n));
}

void AppendJournalFrame(std::string_view payload, std::string* out) {
  char header[kJournalRecordHeaderSize];
  PutLe32(static_cast<uint32_t>(payload.size()), header);
  PutLe32(JournalRecordChecksum(header, payload.data(), payload.size()), header + 4);
  out->append(header, sizeof(header));
  out->append(payload);
}

std::string DecodeJournalPayload(const char* header, const char* payload, uint32_t length,
                                 journal::JournalRecord* record) {
  const uint32_t stored = GetLe32(header + 4);
  const uint32_t computed = JournalRecordChecksum(header, payload, length);
  if (stored != computed) {
    char buf[80];
    std::snprintf(buf, sizeof(buf), "checksum mismatch (stored 0x%08X, computed 0x%08X)", stored,
                  computed);
    return buf;
  }
  if (!record->ParseFromArray(payload, static_cast<int>(length))) {
    return "checksum ok but the payload does not parse as a JournalRecord";
  }
  if (record->kind_case() == journal::JournalRecord::KIND_NOT_SET) {
    return "checksum ok but the record has no kind";
  }
  return "";
}

}  // namespace slamd::server::internal
