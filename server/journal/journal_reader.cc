#include "server/journal/journal_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "server/journal/file_util.h"
#include "server/journal/journal_format.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

constexpr int64_t kScanChunk = 64 * 1024;  // scan buffer [bytes]

}  // namespace

const char* JournalReadStateName(JournalReadState state) {
  switch (state) {
    case JournalReadState::kRecord:
      return "record";
    case JournalReadState::kCleanEnd:
      return "clean end";
    case JournalReadState::kTornTail:
      return "torn tail";
    case JournalReadState::kError:
      return "error";
  }
  return "unknown";
}

core::Result<std::unique_ptr<JournalReader>> JournalReader::Open(
    const std::string& path, const JournalReaderOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    const std::string m = "cannot open journal " + path + ": " + internal::ErrnoDescription(err);
    return err == ENOENT ? core::NotFound(m) : core::IoError(m);
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return core::IoError("cannot stat journal " + path + ": " + internal::ErrnoDescription(err));
  }
  const int64_t size = st.st_size;
  char header[kJournalHeaderSize] = {};
  const int64_t got = internal::PreadUpTo(fd, header, sizeof(header), 0);
  if (got < 0) {
    const int err = errno;
    ::close(fd);
    return core::IoError("cannot read journal " + path + ": " + internal::ErrnoDescription(err));
  }
  std::unique_ptr<JournalReader> reader(new JournalReader(path, fd, size, options));
  if (got < kJournalHeaderSize) {
    // A crash while creating the file leaves a prefix of the header: torn at 0.
    const std::string expected = internal::EncodeJournalHeader();
    if (std::memcmp(header, expected.data(), static_cast<std::size_t>(got)) != 0) {
      return core::DataLoss("journal " + path + " at offset 0: " + std::to_string(got) +
                            "-byte file is not a slamd journal (bad magic)");
    }
    reader->state_ = JournalReadState::kTornTail;
    reader->torn_tail_offset_ = 0;
    reader->end_reason_ = "incomplete file header (" + std::to_string(got) + " of " +
                          std::to_string(kJournalHeaderSize) + " bytes)";
    return reader;
  }
  const std::string why = internal::CheckJournalHeader(header);
  if (!why.empty()) return core::DataLoss("journal " + path + " at offset 0: " + why);
  reader->pos_ = kJournalHeaderSize;
  reader->valid_end_offset_ = kJournalHeaderSize;
  return reader;
}

JournalReader::JournalReader(std::string path, int fd, int64_t file_size,
                             const JournalReaderOptions& options)
    : path_(std::move(path)),
      fd_(fd),
      file_size_(file_size),
      options_(options),
      scratch_(std::make_unique<journal::JournalRecord>()) {}

JournalReader::~JournalReader() {
  if (fd_ >= 0) ::close(fd_);
}

JournalReader::Probe JournalReader::ProbeAt(int64_t p, journal::JournalRecord* record,
                                            int64_t* frame_size, std::string* why) {
  const int64_t avail = file_size_ - p;
  if (avail < kJournalRecordHeaderSize) {
    *why = "incomplete record header (" + std::to_string(avail) + " of " +
           std::to_string(kJournalRecordHeaderSize) + " bytes)";
    return Probe::kInvalid;
  }
  char header[kJournalRecordHeaderSize];
  if (internal::PreadUpTo(fd_, header, sizeof(header), p) != kJournalRecordHeaderSize) {
    *why = "read of journal " + path_ + " at offset " + std::to_string(p) +
           " failed: " + internal::ErrnoDescription(errno);
    return Probe::kReadError;
  }
  const uint32_t length = internal::GetLe32(header);
  if (length == 0 || length > kJournalMaxRecordPayload) {
    *why = "record length " + std::to_string(length) + " out of range 1.." +
           std::to_string(kJournalMaxRecordPayload);
    return Probe::kInvalid;
  }
  if (int64_t{length} > avail - kJournalRecordHeaderSize) {
    *why = "incomplete record: " + std::to_string(length) + "-byte payload, " +
           std::to_string(avail - kJournalRecordHeaderSize) + " bytes present";
    return Probe::kInvalid;
  }
  payload_.resize(length);
  if (internal::PreadUpTo(fd_, payload_.data(), length, p + kJournalRecordHeaderSize) != length) {
    *why = "read of journal " + path_ + " at offset " + std::to_string(p) +
           " failed: " + internal::ErrnoDescription(errno);
    return Probe::kReadError;
  }
  *why = internal::DecodeJournalPayload(header, payload_.data(), length, record);
  if (!why->empty()) return Probe::kInvalid;
  *frame_size = kJournalRecordHeaderSize + length;
  return Probe::kValid;
}

int64_t JournalReader::FindNextValid(int64_t from, std::string* why) {
  // Reads the file in chunks and only probes positions whose length field is plausible, so the
  // byte-by-byte scan costs one pass over the bytes plus a few checksums.
  std::string buf(static_cast<std::size_t>(kScanChunk + kJournalRecordHeaderSize), '\0');
  int64_t p = from;
  while (p + kJournalRecordHeaderSize <= file_size_) {
    const int64_t want = std::min<int64_t>(static_cast<int64_t>(buf.size()), file_size_ - p);
    const int64_t n = internal::PreadUpTo(fd_, buf.data(), static_cast<std::size_t>(want), p);
    if (n < 0) {
      *why = "read of journal " + path_ + " at offset " + std::to_string(p) +
             " failed: " + internal::ErrnoDescription(errno);
      return -2;
    }
    if (n < kJournalRecordHeaderSize) return -1;
    for (int64_t i = 0; i + kJournalRecordHeaderSize <= n; ++i) {
      const uint32_t length = internal::GetLe32(buf.data() + i);
      if (length == 0 || length > kJournalMaxRecordPayload) continue;
      if (p + i + kJournalRecordHeaderSize + int64_t{length} > file_size_) continue;
      if (i + kJournalRecordHeaderSize < n &&
          !internal::PlausibleRecordStart(
              buf[static_cast<std::size_t>(i + kJournalRecordHeaderSize)])) {
        continue;
      }
      int64_t frame = 0;
      const Probe probe = ProbeAt(p + i, scratch_.get(), &frame, why);
      if (probe == Probe::kValid) return p + i;
      if (probe == Probe::kReadError) return -2;
    }
    p += n - (kJournalRecordHeaderSize - 1);  // the last 7 positions were not checked yet
  }
  return -1;
}

JournalReadState JournalReader::Next(journal::JournalRecord* record, int64_t* offset) {
  if (state_ != JournalReadState::kRecord) return state_;
  if (pos_ == file_size_) return state_ = JournalReadState::kCleanEnd;
  int64_t frame = 0;
  std::string why;
  Probe probe = ProbeAt(pos_, record, &frame, &why);
  if (probe == Probe::kReadError) {
    error_ = core::IoError(why);
    return state_ = JournalReadState::kError;
  }
  if (probe == Probe::kInvalid) {
    // Torn tail or corruption: decided by whether any valid record follows (header comment).
    std::string scan_error;
    const int64_t next = FindNextValid(pos_ + 1, &scan_error);
    if (next == -2) {
      error_ = core::IoError(scan_error);
      return state_ = JournalReadState::kError;
    }
    end_reason_ = why;
    if (next < 0) {
      torn_tail_offset_ = pos_;
      return state_ = JournalReadState::kTornTail;
    }
    if (!options_.salvage) {
      error_ =
          core::DataLoss("journal " + path_ + ": corrupt record at offset " + std::to_string(pos_) +
                         " (" + why + "); a valid record follows at offset " +
                         std::to_string(next) + ", so this is not a torn tail; " +
                         std::to_string(next - pos_) + " bytes would be skipped with salvage");
      return state_ = JournalReadState::kError;
    }
    skipped_.push_back({.offset = pos_, .length = next - pos_, .reason = why});
    skipped_bytes_ += next - pos_;
    pos_ = next;
    probe = ProbeAt(pos_, record, &frame, &why);
    if (probe != Probe::kValid) {  // valid a moment ago: only a read error can get here
      error_ = core::IoError(why);
      return state_ = JournalReadState::kError;
    }
  }
  if (offset != nullptr) *offset = pos_;
  pos_ += frame;
  valid_end_offset_ = pos_;
  ++records_read_;
  return JournalReadState::kRecord;
}

core::Status TruncateTornTail(const std::string& path, int64_t offset) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    return core::IoError("cannot open journal " + path +
                         " to truncate it: " + internal::ErrnoDescription(errno));
  }
  struct stat st {};
  core::Status s;
  if (::fstat(fd, &st) != 0) {
    s = core::IoError("cannot stat journal " + path + ": " + internal::ErrnoDescription(errno));
  } else if (offset < 0 || offset > st.st_size) {
    s = core::InvalidArgument("cannot truncate journal " + path + " at offset " +
                              std::to_string(offset) + ": the file has " +
                              std::to_string(st.st_size) + " bytes");
  } else if (::ftruncate(fd, static_cast<off_t>(offset)) != 0) {
    s = core::IoError("cannot truncate journal " + path + " at offset " + std::to_string(offset) +
                      ": " + internal::ErrnoDescription(errno));
  } else if (::fdatasync(fd) != 0) {
    s = core::IoError("fdatasync of journal " + path +
                      " after truncation failed: " + internal::ErrnoDescription(errno));
  }
  ::close(fd);
  return s;
}

}  // namespace slamd::server
