// Fuzz target: the journal reader (server/journal/journal_reader.h) over a scratch file, with
// and without salvage, and the decoding of the messages it yields (what recovery does with
// them: DecodeInbound of the stored LCM bytes).
//
// Input: byte 0 = options. Bit 0: salvage. Bits 1-2: the file layout,
//   0     the rest of the input is the whole file (bad headers, torn headers);
//   1     a valid header, then the rest of the input as raw bytes;
//   2, 3  a valid header, then chunks [u8 tag][u16 length LE][length bytes]: a chunk with tag
//         bit 0 clear is framed as a record with a correct checksum (journal_format.h
//         AppendJournalFrame), so the fuzzer reaches the protobuf parse and what follows; with
//         bit 0 set it is appended raw (corruption, torn tails). A short last chunk is cut.
// Properties:
//   1. Open/Next never crash; every end state is one of the documented ones, and kError only
//      without salvage.
//   2. After a torn tail at X (past the header), TruncateTornTail(X) and a new reader gives a
//      clean end with the same records; ReadJournal agrees with the streaming reader.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "server/journal/journal_format.h"
#include "server/journal/journal_reader.h"
#include "server/journal/read_journal.h"
#include "server/messages/inbound_codec.h"
#include "slamd_proto/journal.pb.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::server {
namespace {

std::string BuildFile(const std::uint8_t* data, std::size_t size, int layout) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  if (layout == 0) return std::string(rest);
  std::string file = internal::EncodeJournalHeader();
  if (layout == 1) return file + std::string(rest);
  while (rest.size() >= 3) {
    const std::uint8_t tag = static_cast<std::uint8_t>(rest[0]);
    std::size_t n = static_cast<std::uint8_t>(rest[1]) | (static_cast<std::uint8_t>(rest[2]) << 8);
    rest.remove_prefix(3);
    n = std::min(n, rest.size());
    const std::string_view chunk = rest.substr(0, n);
    rest.remove_prefix(n);
    if ((tag & 1) != 0 || chunk.empty()) {
      file.append(chunk);
    } else {
      internal::AppendJournalFrame(chunk, &file);
    }
  }
  return file;
}

struct ReadSummary {
  JournalReadState end = JournalReadState::kRecord;
  int64_t records = 0;
  int64_t torn_tail_offset = -1;
};

ReadSummary ReadAll(const std::string& path, const JournalReaderOptions& options) {
  ReadSummary s;
  auto reader = JournalReader::Open(path, options);
  if (!reader.ok()) return s;
  journal::JournalRecord record;
  int64_t offset = -1;
  for (int guard = 0;; ++guard) {
    if (guard > 1000000) fuzz::Fail("JournalReader::Next does not terminate");
    const JournalReadState state = reader.value()->Next(&record, &offset);
    if (state != JournalReadState::kRecord) {
      s.end = state;
      break;
    }
    ++s.records;
    if (offset < kJournalHeaderSize || offset >= reader.value()->file_size()) {
      fuzz::Fail("record offset " + std::to_string(offset) + " outside the file");
    }
    if (record.has_message()) {  // what recovery does with a stored message
      const std::string& payload = record.message().lcm_payload();
      (void)DecodeInbound(
          record.message().message_type(),
          std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(payload.data()),
                                        payload.size()));
    }
  }
  if (s.end == JournalReadState::kError && options.salvage) {
    // Salvage never stops on corruption, only on a read error (impossible on a scratch file).
    fuzz::Fail("kError under salvage: " + reader.value()->error().ToString());
  }
  if (reader.value()->records_read() != s.records) fuzz::Fail("records_read() disagrees");
  s.torn_tail_offset = reader.value()->torn_tail_offset();
  if (s.end == JournalReadState::kTornTail &&
      (s.torn_tail_offset < 0 || s.torn_tail_offset > reader.value()->file_size())) {
    fuzz::Fail("torn_tail_offset " + std::to_string(s.torn_tail_offset) + " outside the file");
  }
  return s;
}

void RunJournal(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return;
  JournalReaderOptions options;
  options.salvage = (data[0] & 1) != 0;
  const int layout = (data[0] >> 1) & 3;
  static const std::string kPath = fuzz::ScratchPath("journal", ".jnl");
  fuzz::WriteFileOrDie(kPath, BuildFile(data + 1, size - 1, layout));

  const ReadSummary first = ReadAll(kPath, options);   // 1.
  if (first.end == JournalReadState::kRecord) return;  // Open failed (bad header): fine

  core::Result<JournalContents> contents = ReadJournal(kPath, options);  // 2.
  if (first.end == JournalReadState::kError) {
    if (contents.ok()) fuzz::Fail("ReadJournal ok where JournalReader stopped with kError");
    return;
  }
  if (!contents.ok()) fuzz::Fail("ReadJournal failed: " + contents.status().ToString());
  if (static_cast<int64_t>(contents.value().records.size()) != first.records) {
    fuzz::Fail("ReadJournal record count differs");
  }
  if (first.end != JournalReadState::kTornTail || first.torn_tail_offset < kJournalHeaderSize) {
    return;
  }
  const core::Status truncated = TruncateTornTail(kPath, first.torn_tail_offset);
  if (!truncated.ok()) fuzz::Fail("TruncateTornTail: " + truncated.ToString());
  const ReadSummary second = ReadAll(kPath, options);
  if (second.end != JournalReadState::kCleanEnd || second.records != first.records) {
    fuzz::Fail("after TruncateTornTail: state " + std::string(JournalReadStateName(second.end)) +
               ", " + std::to_string(second.records) +
               " records (before: " + std::to_string(first.records) + ")");
  }
}

}  // namespace
}  // namespace slamd::server

namespace slamd::fuzz {
void FuzzJournal(const std::uint8_t* data, std::size_t size) { server::RunJournal(data, size); }
}  // namespace slamd::fuzz

SLAMD_FUZZ_ENTRY_POINT(slamd::fuzz::FuzzJournal)
