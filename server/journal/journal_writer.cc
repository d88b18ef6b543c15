#include "server/journal/journal_writer.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

#include "core/base/param_check.h"
#include "server/journal/file_util.h"
#include "server/journal/journal_format.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

const char* SyncPolicyName(SyncPolicy policy) {
  switch (policy) {
    case SyncPolicy::kAlways:
      return "always";
    case SyncPolicy::kInterval:
      return "interval";
    case SyncPolicy::kNever:
      return "never";
  }
  return "unknown";
}

core::Status JournalWriterOptions::Validate() const {
  SLAMD_PARAM_CHECK(JournalWriterOptions, interval_ms, >=, 1);
  if (sync_policy != SyncPolicy::kAlways && sync_policy != SyncPolicy::kInterval &&
      sync_policy != SyncPolicy::kNever) {
    return core::InvalidArgument(
        "JournalWriterOptions::sync_policy = " + std::to_string(static_cast<int>(sync_policy)) +
        "; not one of kAlways, kInterval, kNever");
  }
  return core::Status::Ok();
}

core::Result<std::unique_ptr<JournalWriter>> JournalWriter::Open(
    const std::string& path, const JournalWriterOptions& options) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  // No O_APPEND: every write is a pwrite at offset_, which stays correct after truncating a
  // partial record (and Linux ignores pwrite's offset on O_APPEND files).
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, internal::kDataFileMode);
  if (fd < 0) {
    return core::IoError("cannot open journal " + path + ": " + internal::ErrnoDescription(errno));
  }
  auto fail = [fd](core::Status s) {
    ::close(fd);
    return s;
  };
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    return fail(
        core::IoError("cannot stat journal " + path + ": " + internal::ErrnoDescription(errno)));
  }
  const int64_t size = st.st_size;
  if (size == 0) {
    // 1. New (or empty) file: header, then make both the bytes and the directory entry durable.
    const std::string header = internal::EncodeJournalHeader();
    core::Status s =
        internal::PwriteAll(fd, header.data(), header.size(), 0, path, "journal header", nullptr);
    if (!s.ok()) {
      if (::ftruncate(fd, 0) != 0) {
        // Nothing more to do: the next Open finds a short file and says so.
      }
      return fail(s);
    }
    if (::fdatasync(fd) != 0) {
      return fail(core::IoError("fdatasync of journal " + path +
                                " failed: " + internal::ErrnoDescription(errno)));
    }
    s = internal::SyncDirectory(internal::DirName(path));
    if (!s.ok()) return fail(s);
  } else if (size < kJournalHeaderSize) {
    return fail(core::FailedPrecondition(
        "journal " + path + " has " + std::to_string(size) + " bytes, less than its " +
        std::to_string(kJournalHeaderSize) +
        "-byte header (a torn create): read it with JournalReader and TruncateTornTail first"));
  } else {
    // 2. Existing file: check the header, then sync what a previous process left in the page
    //    cache so durable_offset() is true from the start.
    char header[kJournalHeaderSize];
    if (internal::PreadUpTo(fd, header, sizeof(header), 0) != kJournalHeaderSize) {
      return fail(core::IoError("cannot read the header of journal " + path + ": " +
                                internal::ErrnoDescription(errno)));
    }
    const std::string why = internal::CheckJournalHeader(header);
    if (!why.empty()) return fail(core::DataLoss("journal " + path + " at offset 0: " + why));
    if (::fdatasync(fd) != 0) {
      return fail(core::IoError("fdatasync of journal " + path +
                                " failed: " + internal::ErrnoDescription(errno)));
    }
  }
  return std::unique_ptr<JournalWriter>(
      new JournalWriter(path, fd, options, size == 0 ? kJournalHeaderSize : size));
}

JournalWriter::JournalWriter(std::string path, int fd, const JournalWriterOptions& options,
                             int64_t offset)
    : path_(std::move(path)),
      fd_(fd),
      options_(options),
      offset_(offset),
      durable_offset_(offset),
      last_sync_(Clock::now()) {}

JournalWriter::~JournalWriter() {
  if (fd_ >= 0) ::close(fd_);
}

core::Status JournalWriter::TruncateToOffset() {
  if (::ftruncate(fd_, static_cast<off_t>(offset_)) != 0) {
    tail_dirty_ = true;
    return core::IoError(
        "cannot truncate journal " + path_ + " back to offset " + std::to_string(offset_) +
        " (the end of the last complete record): " + internal::ErrnoDescription(errno));
  }
  tail_dirty_ = false;
  return core::Status::Ok();
}

core::Result<int64_t> JournalWriter::Append(const journal::JournalRecord& record) {
  if (fd_ < 0) return core::FailedPrecondition("journal " + path_ + " is closed");
  if (record.kind_case() == journal::JournalRecord::KIND_NOT_SET) {
    return core::InvalidArgument("journal record without a kind (message or boundary)");
  }
  const std::size_t n = record.ByteSizeLong();
  if (n > kJournalMaxRecordPayload) {
    return core::InvalidArgument("journal record of " + std::to_string(n) +
                                 " bytes exceeds the maximum of " +
                                 std::to_string(kJournalMaxRecordPayload));
  }
  // 1. A previous failed write whose truncation failed too: drop its bytes first.
  if (tail_dirty_) SLAMD_RETURN_IF_ERROR(TruncateToOffset());
  // 2. Frame into one buffer, so the record goes out in one pwrite (one syscall, and a crash
  //    mid-write tears at most this record).
  buffer_.resize(kJournalRecordHeaderSize + n);
  record.SerializeWithCachedSizesToArray(
      reinterpret_cast<uint8_t*>(buffer_.data() + kJournalRecordHeaderSize));
  internal::PutLe32(static_cast<uint32_t>(n), buffer_.data());
  internal::PutLe32(
      internal::JournalRecordChecksum(buffer_.data(), buffer_.data() + kJournalRecordHeaderSize, n),
      buffer_.data() + 4);
  // 3. Write; on failure cut the file back to the last complete record.
  std::size_t written = 0;
  core::Status s = internal::PwriteAll(fd_, buffer_.data(), buffer_.size(), offset_, path_,
                                       "journal record", &written);
  if (!s.ok()) {
    const core::Status t = TruncateToOffset();
    if (!t.ok()) return core::IoError(s.message() + "; and " + t.message());
    return s;
  }
  offset_ += static_cast<int64_t>(buffer_.size());
  ++records_;
  return offset_;
}

core::Status JournalWriter::Sync() {
  if (fd_ < 0) return core::FailedPrecondition("journal " + path_ + " is closed");
  if (!sync_pending()) return core::Status::Ok();
  if (::fdatasync(fd_) != 0) {
    return core::IoError("fdatasync of journal " + path_ + " (up to offset " +
                         std::to_string(offset_) +
                         ") failed: " + internal::ErrnoDescription(errno));
  }
  ++syncs_;
  durable_offset_ = offset_;
  last_sync_ = Clock::now();
  return core::Status::Ok();
}

core::Status JournalWriter::MaybeSync(Clock::time_point now) {
  if (fd_ < 0) return core::FailedPrecondition("journal " + path_ + " is closed");
  switch (options_.sync_policy) {
    case SyncPolicy::kNever:
      return core::Status::Ok();
    case SyncPolicy::kAlways:
      return Sync();
    case SyncPolicy::kInterval:
      if (sync_pending() && now - last_sync_ >= std::chrono::milliseconds(options_.interval_ms)) {
        SLAMD_RETURN_IF_ERROR(Sync());
        last_sync_ = now;
      }
      return core::Status::Ok();
  }
  return core::Status::Ok();
}

core::Status JournalWriter::Close() {
  if (fd_ < 0) return core::Status::Ok();
  core::Status s = Sync();
  ::close(fd_);
  fd_ = -1;
  return s;
}

}  // namespace slamd::server
