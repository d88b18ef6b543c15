#include "server/replication/stream_reader.h"

#include <nats/nats.h>

#include <algorithm>

#include "server/journal/journal_format.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

core::Result<std::unique_ptr<StreamReader>> StreamReader::Open(const StreamJournalOptions& options,
                                                               const FollowPoint& from) {
  if (from.sequence < 1 || from.stream_offset < 0) {
    return core::InvalidArgument("StreamReader: from = message " + std::to_string(from.sequence) +
                                 " at stream offset " + std::to_string(from.stream_offset) +
                                 "; violates sequence >= 1, offset >= 0");
  }
  core::Result<std::unique_ptr<NatsClient>> client = NatsClient::Connect(options.nats);
  if (!client.ok()) return client.status();
  jsOptions jo;
  jsOptions_Init(&jo);
  jo.Wait = std::max(options.ack_timeout_ms, kNatsAdminWaitMs);
  jsSubOptions so;
  jsSubOptions_Init(&so);
  so.Stream = options.stream.c_str();
  so.Ordered = true;
  so.Config.DeliverPolicy = js_DeliverByStartSequence;
  so.Config.OptStartSeq = static_cast<std::uint64_t>(from.sequence);
  natsSubscription* sub = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  const natsStatus s =
      js_SubscribeSync(&sub, client.value()->jetstream(), options.subject.c_str(), &jo, &so, &jerr);
  if (s != NATS_OK) {
    return NatsStatus(("cannot follow stream " + options.stream).c_str(), s, jerr);
  }
  return std::unique_ptr<StreamReader>(
      new StreamReader(std::move(client).value(), sub, options.stream, from.stream_offset));
}

StreamReader::~StreamReader() {
  natsSubscription_Unsubscribe(sub_);
  natsSubscription_Destroy(sub_);
}

core::Result<bool> StreamReader::TakeFrame(journal::JournalRecord* record) {
  const size_t avail = buffer_.size() - next_;
  if (avail < kJournalRecordHeaderSize) return false;
  const char* header = buffer_.data() + next_;
  const uint32_t length = internal::GetLe32(header);
  if (length == 0 || length > kJournalMaxRecordPayload) {
    return core::DataLoss("stream " + stream_ + " after message " +
                          std::to_string(position_.sequence) + ": record length " +
                          std::to_string(length) + " out of range");
  }
  if (avail < kJournalRecordHeaderSize + length) return false;
  const std::string why =
      internal::DecodeJournalPayload(header, header + kJournalRecordHeaderSize, length, record);
  if (!why.empty()) {
    return core::DataLoss("stream " + stream_ + " after message " +
                          std::to_string(position_.sequence) + ": " + why);
  }
  next_ += kJournalRecordHeaderSize + length;
  if (offset_ >= 0) offset_ += static_cast<std::int64_t>(kJournalRecordHeaderSize + length);
  if (next_ == buffer_.size()) {  // everything received is returned
    buffer_.clear();
    next_ = 0;
    position_ = received_;
  }
  return true;
}

core::Result<bool> StreamReader::Next(journal::JournalRecord* record, int timeout_ms) {
  while (true) {
    core::Result<bool> taken = TakeFrame(record);
    if (!taken.ok() || taken.value()) return taken;
    natsMsg* m = nullptr;
    const natsStatus s = natsSubscription_NextMsg(&m, sub_, timeout_ms);
    if (s == NATS_TIMEOUT) return false;
    if (s != NATS_OK) return NatsStatus(("reading stream " + stream_).c_str(), s);
    if (next_ > 0) {  // drop what was returned before appending
      buffer_.erase(0, next_);
      next_ = 0;
    }
    StreamPosition p = PositionOf(m);
    jsMsgMetaData* meta = nullptr;  // a consumer's message has its stream sequence here
    if (natsMsg_GetMetaData(&meta, m) == NATS_OK) {
      p.sequence = static_cast<std::int64_t>(meta->Sequence.Stream);
      jsMsgMetaData_Destroy(meta);
    }
    const auto length = static_cast<std::int64_t>(natsMsg_GetDataLength(m));
    const auto buffered = static_cast<std::int64_t>(buffer_.size());  // next_ = 0
    std::int64_t skip = 0;
    if (p.stream_offset < 0) {
      offset_ = -1;  // a writer from before the header: nothing to check
    } else if (offset_ < 0) {
      offset_ = p.stream_offset - buffered;
    } else if (p.stream_offset > offset_ + buffered) {
      natsMsg_Destroy(m);
      return core::DataLoss("stream " + stream_ + ": message " + std::to_string(p.sequence) +
                            " starts at stream offset " + std::to_string(p.stream_offset) +
                            ", this reader is at " + std::to_string(offset_ + buffered) +
                            ": the records in between are no longer in the stream (truncated "
                            "after a snapshot?)");
    } else {
      skip = std::min(length, offset_ + buffered - p.stream_offset);
    }
    if (skip == length) ++repeated_messages_;
    buffer_.append(natsMsg_GetData(m) + skip, static_cast<size_t>(length - skip));
    natsMsg_Destroy(m);
    received_ = std::move(p);
    if (buffer_.empty()) position_ = received_;  // nothing new: all of it returned before
  }
}

}  // namespace slamd::server
