#include "server/replication/stream_reader.h"

#include <nats/nats.h>

#include <algorithm>

#include "server/journal/journal_format.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::server {

core::Result<std::unique_ptr<StreamReader>> StreamReader::Open(const StreamJournalOptions& options,
                                                               std::int64_t from_sequence) {
  if (from_sequence < 1) {
    return core::InvalidArgument("StreamReader: from_sequence = " + std::to_string(from_sequence) +
                                 "; violates >= 1");
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
  so.Config.OptStartSeq = static_cast<std::uint64_t>(from_sequence);
  natsSubscription* sub = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  const natsStatus s =
      js_SubscribeSync(&sub, client.value()->jetstream(), options.subject.c_str(), &jo, &so, &jerr);
  if (s != NATS_OK) {
    return NatsStatus(("cannot follow stream " + options.stream).c_str(), s, jerr);
  }
  return std::unique_ptr<StreamReader>(
      new StreamReader(std::move(client).value(), sub, options.stream));
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
    buffer_.append(natsMsg_GetData(m), static_cast<size_t>(natsMsg_GetDataLength(m)));
    received_ = PositionOf(m);
    jsMsgMetaData* meta = nullptr;  // a consumer's message has its stream sequence here
    if (natsMsg_GetMetaData(&meta, m) == NATS_OK) {
      received_.sequence = static_cast<std::int64_t>(meta->Sequence.Stream);
      jsMsgMetaData_Destroy(meta);
    }
    natsMsg_Destroy(m);
  }
}

}  // namespace slamd::server
