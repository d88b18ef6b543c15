// StreamReader: reads the replicated journal (stream_journal.h) back, record by record, from a
// given stream message on, following the stream as it grows (a JetStream ordered consumer: the
// client library restarts it after a gap or a lost connection). The standby applies what it
// reads; tests compare it with the local journal.
//
// The payloads of consecutive stream messages are one byte stream of journal frames
// (journal_format.h: length, masked CRC32C, JournalRecord); a frame may span messages. Each
// message says where it starts in the stream's bytes (Slamd-Stream-Offset): bytes the reader
// already has (a batch the writer sent again after the stream lost it) are skipped, and a message
// that starts past the reader (the stream truncated before it was read) is DataLoss.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/base/status.h"
#include "server/replication/nats_client.h"
#include "server/replication/stream_journal.h"

typedef struct __natsSubscription natsSubscription;

namespace slamd::journal {
class JournalRecord;
}

namespace slamd::server {

class StreamReader {
 public:
  // Starts at stream message from.sequence (>= 1), which begins with a record at
  // from.stream_offset ({1, 0}: the beginning; from.skip is the caller's). The options' nats,
  // stream and subject are used; Unavailable when NATS does not answer.
  static core::Result<std::unique_ptr<StreamReader>> Open(const StreamJournalOptions& options,
                                                          const FollowPoint& from);
  ~StreamReader();
  StreamReader(const StreamReader&) = delete;
  StreamReader& operator=(const StreamReader&) = delete;

  // The next record, waiting up to timeout_ms for the stream to bring it: true with *record
  // filled, false when nothing came in time; DataLoss on a frame that does not check (corrupt,
  // or a message that does not continue the previous one).
  core::Result<bool> Next(journal::JournalRecord* record, int timeout_ms);

  // The last stream message all of whose bytes were returned (sequence 0 before the first).
  const StreamPosition& position() const { return position_; }
  // Messages that held only bytes already returned (batches sent again).
  std::int64_t repeated_messages() const { return repeated_messages_; }
  // Bytes received and not yet returned as a record (a frame's beginning).
  std::int64_t buffered_bytes() const { return static_cast<std::int64_t>(buffer_.size() - next_); }

 private:
  StreamReader(std::unique_ptr<NatsClient> client, natsSubscription* sub, std::string stream,
               std::int64_t offset)
      : client_(std::move(client)), sub_(sub), stream_(std::move(stream)), offset_(offset) {}
  // A whole frame at next_: parses it into *record (true), or false when more bytes are needed.
  core::Result<bool> TakeFrame(journal::JournalRecord* record);

  std::unique_ptr<NatsClient> client_;
  natsSubscription* sub_ = nullptr;
  const std::string stream_;
  std::string buffer_;
  size_t next_ = 0;          // first byte of buffer_ not yet returned
  std::int64_t offset_;      // stream offset of buffer_[next_]; -1 when unknown (no header)
  std::int64_t repeated_messages_ = 0;
  StreamPosition position_;  // of the last message whose bytes are all returned
  StreamPosition received_;  // of the last message received
};

}  // namespace slamd::server
