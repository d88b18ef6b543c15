#include "server/replication/replicated_journal.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <random>

#include "server/journal/file_util.h"
#include "server/journal/journal_format.h"
#include "server/journal/journal_segments.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {
namespace {

constexpr const char* kIdFile = "replication-id";

bool IsId(const std::string& s) {
  return s.size() == 16 && s.find_first_not_of("0123456789abcdef") == std::string::npos;
}

// Stages the local records from global offset `from` on (all of them when from = 0).
core::Status StageFrom(const std::string& data_dir, std::int64_t from, StreamJournal* stream) {
  core::Result<std::unique_ptr<SegmentedJournalReader>> opened =
      SegmentedJournalReader::Open(data_dir, {});
  if (!opened.ok() && opened.status().code() == core::StatusCode::kNotFound) {
    return core::Status::Ok();  // no journal yet
  }
  if (!opened.ok()) return opened.status();
  SegmentedJournalReader& reader = *opened.value();
  if (reader.first_offset() > from) {
    return core::FailedPrecondition(
        "the stream ends at journal offset " + std::to_string(from) + " of " + data_dir +
        " but its journal now starts at " + std::to_string(reader.first_offset()) +
        " (older segments deleted): the records in between exist nowhere");
  }
  journal::JournalRecord record;
  std::int64_t offset = 0, last_message = 0;
  std::string payload, frame;
  while (reader.Next(&record, &offset) == JournalReadState::kRecord) {
    if (record.has_message()) last_message = record.message().sequence();
    if (offset < from) continue;
    payload.clear();
    record.SerializeToString(&payload);
    frame.clear();
    internal::AppendJournalFrame(payload, &frame);
    stream->Stage(frame, {.last_message = last_message,
                          .journal_end = offset + static_cast<std::int64_t>(frame.size())});
  }
  if (reader.state() == JournalReadState::kError) return reader.error();
  return core::Status::Ok();
}

// The stream journal that appends data_dir's journal (its id as the source).
core::Result<std::unique_ptr<StreamJournal>> OpenFor(const std::string& data_dir,
                                                     StreamJournalOptions options) {
  core::Result<std::string> id = DataDirectoryId(data_dir);
  if (!id.ok()) return id.status();
  options.source = id.value();
  return StreamJournal::Open(options);
}

}  // namespace

core::Result<std::string> DataDirectoryId(const std::string& data_dir) {
  const std::string path = data_dir + "/" + kIdFile;
  std::ifstream in(path);
  if (in) {
    std::string id;
    std::getline(in, id);
    if (!IsId(id)) return core::DataLoss(path + ": not a replication id (16 hex digits)");
    return id;
  }
  std::random_device rd;
  char id[17];
  std::snprintf(id, sizeof(id), "%08x%08x", rd(), rd());
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) {
    return core::IoError("cannot create " + tmp + ": " + internal::ErrnoDescription(errno));
  }
  std::size_t written = 0;
  core::Status s = internal::PwriteAll(fd, id, 16, 0, tmp, "replication id", &written);
  if (s.ok() && ::fsync(fd) != 0) {
    s = core::IoError("cannot sync " + tmp + ": " + internal::ErrnoDescription(errno));
  }
  ::close(fd);
  if (s.ok() && ::rename(tmp.c_str(), path.c_str()) != 0) {
    s = core::IoError("cannot rename " + tmp + ": " + internal::ErrnoDescription(errno));
  }
  if (s.ok()) s = internal::SyncDirectory(data_dir);
  if (!s.ok()) return s;
  return std::string(id);
}

core::Result<std::unique_ptr<StreamJournal>> StartReplication(const std::string& data_dir,
                                                              StreamJournalOptions options,
                                                              Journal* journal) {
  core::Result<std::unique_ptr<StreamJournal>> opened = OpenFor(data_dir, options);
  if (!opened.ok()) return opened.status();
  std::unique_ptr<StreamJournal> stream = std::move(opened).value();
  const StreamPosition end = stream->stream_end();
  const std::string& source = stream->source();
  std::int64_t from = 0;
  if (end.sequence > 0) {
    if (end.source != source) {
      return core::FailedPrecondition(
          "stream " + options.stream + " was last written from another data directory (id '" +
          end.source + "', this one is '" + source +
          "'): this slamd is behind the stream and can only follow it as a standby");
    }
    if (end.journal_end > journal->offset()) {
      return core::DataLoss("stream " + options.stream + " holds the journal of " + data_dir +
                            " up to offset " + std::to_string(end.journal_end) +
                            " but the journal ends at " + std::to_string(journal->offset()));
    }
    from = end.journal_end;
  }
  SLAMD_RETURN_IF_ERROR(StageFrom(data_dir, from, stream.get()));
  SLAMD_RETURN_IF_ERROR(stream->Commit());
  journal->set_replica(stream.get());
  return stream;
}

core::Result<std::unique_ptr<StreamJournal>> TakeOverReplication(const std::string& data_dir,
                                                                 StreamJournalOptions options,
                                                                 Journal* journal,
                                                                 std::int64_t consumed) {
  core::Result<std::unique_ptr<StreamJournal>> opened = OpenFor(data_dir, options);
  if (!opened.ok()) return opened.status();
  const std::int64_t end = opened.value()->stream_end().sequence;
  if (end != consumed) {
    return core::FailedPrecondition("stream " + options.stream + " ends at message " +
                                    std::to_string(end) + ", this standby has read up to " +
                                    std::to_string(consumed));
  }
  journal->set_replica(opened.value().get());
  return opened;
}

}  // namespace slamd::server
