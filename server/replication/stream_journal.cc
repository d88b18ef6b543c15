#include "server/replication/stream_journal.h"

#include <nats/nats.h>

#include <algorithm>
#include <charconv>
#include <random>

#include "core/base/param_check.h"

namespace slamd::server {
namespace {

constexpr const char* kSourceHeader = "Slamd-Source";
constexpr const char* kJournalEndHeader = "Slamd-Journal-End";
constexpr const char* kLastMessageHeader = "Slamd-Last-Message";
// Acknowledged batches kept to send again should the stream lose them [bytes].
constexpr std::int64_t kRetainBytes = std::int64_t{64} << 20;
constexpr std::int64_t kDuplicateWindowNs = std::int64_t{120} * 1000 * 1000 * 1000;

// 16 hex digits, different for every writer (pid and a random device).
std::string NewWriterId() {
  std::random_device rd;
  const std::uint64_t v = (std::uint64_t{rd()} << 32) ^ rd() ^ std::uint64_t(::getpid());
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::int64_t NumberHeader(natsMsg* msg, const char* key) {
  const char* v = nullptr;
  if (natsMsgHeader_Get(msg, key, &v) != NATS_OK || v == nullptr) return 0;
  std::int64_t n = 0;
  const char* end = v + std::strlen(v);
  if (std::from_chars(v, end, n).ptr != end) return 0;
  return n;
}

jsOptions WaitOptions(int wait_ms) {
  jsOptions jo;
  jsOptions_Init(&jo);
  jo.Wait = wait_ms;
  return jo;
}

// The newest message of the stream (its position) and its Nats-Msg-Id.
core::Result<std::pair<StreamPosition, std::string>> ReadNewest(jsCtx* js,
                                                                const StreamJournalOptions& o) {
  jsOptions jo = WaitOptions(o.ack_timeout_ms);
  natsMsg* m = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  const natsStatus s = js_GetLastMsg(&m, js, o.stream.c_str(), o.subject.c_str(), &jo, &jerr);
  if (s == NATS_NOT_FOUND) return std::pair<StreamPosition, std::string>{};  // empty
  if (s != NATS_OK) {
    return NatsStatus(("cannot read the last message of stream " + o.stream).c_str(), s, jerr);
  }
  std::pair<StreamPosition, std::string> out{PositionOf(m), ""};
  const char* id = nullptr;
  if (natsMsgHeader_Get(m, "Nats-Msg-Id", &id) == NATS_OK && id != nullptr) out.second = id;
  natsMsg_Destroy(m);
  return out;
}

}  // namespace

core::Status StreamJournalOptions::Validate() const {
  SLAMD_RETURN_IF_ERROR(nats.Validate());
  if (!IsNatsName(stream)) {
    return core::InvalidArgument("StreamJournalOptions::stream = '" + stream +
                                 "'; violates [A-Za-z0-9_-]+");
  }
  if (!IsNatsSubject(subject)) {
    return core::InvalidArgument("StreamJournalOptions::subject = '" + subject +
                                 "'; violates: [A-Za-z0-9_-]+ tokens joined by dots");
  }
  SLAMD_PARAM_CHECK(StreamJournalOptions, replicas, >=, 1);
  SLAMD_PARAM_CHECK(StreamJournalOptions, replicas, <=, 5);
  SLAMD_PARAM_CHECK(StreamJournalOptions, ack_timeout_ms, >=, 1);
  SLAMD_PARAM_CHECK(StreamJournalOptions, ack_timeout_ms, <=, 60000);
  SLAMD_PARAM_CHECK(StreamJournalOptions, max_batch_bytes, >=, 4096);
  SLAMD_PARAM_CHECK(StreamJournalOptions, max_batch_bytes, <=, 1000000);
  if (source.empty()) return core::InvalidArgument("StreamJournalOptions::source: empty");
  return core::Status::Ok();
}

StreamPosition PositionOf(natsMsg* msg) {
  StreamPosition p{.sequence = static_cast<std::int64_t>(natsMsg_GetSequence(msg)),
                   .journal_end = NumberHeader(msg, kJournalEndHeader),
                   .last_message = NumberHeader(msg, kLastMessageHeader)};
  const char* v = nullptr;
  if (natsMsgHeader_Get(msg, kSourceHeader, &v) == NATS_OK && v != nullptr) p.source = v;
  return p;
}

core::Result<std::unique_ptr<StreamJournal>> StreamJournal::Open(
    const StreamJournalOptions& options) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  core::Result<std::unique_ptr<NatsClient>> client = NatsClient::Connect(options.nats);
  if (!client.ok()) return client.status();
  jsCtx* js = client.value()->jetstream();
  jsOptions jo = WaitOptions(std::max(options.ack_timeout_ms, kNatsAdminWaitMs));
  jsStreamInfo* si = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  natsStatus s = js_GetStreamInfo(&si, js, options.stream.c_str(), &jo, &jerr);
  if (s == NATS_NOT_FOUND) {
    jsStreamConfig cfg;
    jsStreamConfig_Init(&cfg);
    const char* subjects[] = {options.subject.c_str()};
    cfg.Name = options.stream.c_str();
    cfg.Subjects = subjects;
    cfg.SubjectsLen = 1;
    cfg.Storage = js_FileStorage;
    cfg.Replicas = options.replicas;
    cfg.Duplicates = kDuplicateWindowNs;
    jerr = static_cast<jsErrCode>(0);
    s = js_AddStream(&si, js, &cfg, &jo, &jerr);
    if (s != NATS_OK) {
      return NatsStatus(("cannot create stream " + options.stream).c_str(), s, jerr);
    }
  } else if (s != NATS_OK) {
    return NatsStatus(("cannot read stream " + options.stream).c_str(), s, jerr);
  }
  const bool same_subject =
      si->Config->SubjectsLen == 1 && options.subject == si->Config->Subjects[0];
  const std::int64_t last = static_cast<std::int64_t>(si->State.LastSeq);
  jsStreamInfo_Destroy(si);
  if (!same_subject) {
    return core::FailedPrecondition("stream " + options.stream +
                                    " exists and does not capture exactly the subject " +
                                    options.subject);
  }
  StreamPosition end;
  if (last > 0) {
    auto newest = ReadNewest(js, options);
    if (!newest.ok()) return newest.status();
    end = std::move(newest).value().first;
  }
  return std::unique_ptr<StreamJournal>(
      new StreamJournal(options, std::move(client).value(), std::move(end)));
}

StreamJournal::StreamJournal(const StreamJournalOptions& options,
                             std::unique_ptr<NatsClient> client, StreamPosition end)
    : options_(options),
      client_(std::move(client)),
      writer_id_(NewWriterId()),
      end_(std::move(end)) {}

void StreamJournal::Stage(std::string_view frame, Position after) {
  std::lock_guard lock(stage_mutex_);
  staged_.append(frame);
  marks_.push_back({.end = staged_.size(), .position = after});
}

void StreamJournal::CutBatchesLocked() {
  const size_t max = static_cast<size_t>(options_.max_batch_bytes);
  size_t begin = 0, next = 0;  // next: the first mark not yet in a batch
  while (begin < staged_.size()) {
    size_t end = begin;
    while (next < marks_.size() && marks_[next].end - begin <= max) {  // whole records
      end = marks_[next].end;
      cut_ = marks_[next].position;
      ++next;
    }
    if (end == begin) end = std::min(staged_.size(), begin + max);  // a longer record, cut
    pending_.push_back({.id = writer_id_ + "-" + std::to_string(next_batch_++),
                        .bytes = staged_.substr(begin, end - begin),
                        .end = cut_});
    begin = end;
  }
  staged_.clear();
  marks_.clear();
}

void StreamJournal::Stored(Batch batch, std::int64_t sequence) {
  end_ = {.sequence = std::max(end_.sequence, sequence),
          .source = options_.source,
          .journal_end = batch.end.journal_end,
          .last_message = batch.end.last_message};
  ++batches_published_;
  acked_bytes_ += static_cast<std::int64_t>(batch.bytes.size());
  acked_.push_back(std::move(batch));
  while (acked_bytes_ > kRetainBytes && acked_.size() > 1) {
    acked_bytes_ -= static_cast<std::int64_t>(acked_.front().bytes.size());
    acked_.pop_front();
    retained_all_ = false;
  }
}

StreamJournal::Sent StreamJournal::Publish(const Batch& batch, std::int64_t* sequence,
                                           core::Status* error) {
  natsMsg* m = nullptr;
  const std::string expected = std::to_string(end_.sequence);
  const std::string journal_end = std::to_string(batch.end.journal_end);
  const std::string last_message = std::to_string(batch.end.last_message);
  natsStatus s = natsMsg_Create(&m, options_.subject.c_str(), nullptr, batch.bytes.data(),
                                static_cast<int>(batch.bytes.size()));
  if (s == NATS_OK) s = natsMsgHeader_Set(m, "Nats-Msg-Id", batch.id.c_str());
  if (s == NATS_OK) s = natsMsgHeader_Set(m, "Nats-Expected-Last-Sequence", expected.c_str());
  if (s == NATS_OK) s = natsMsgHeader_Set(m, kSourceHeader, options_.source.c_str());
  if (s == NATS_OK) s = natsMsgHeader_Set(m, kJournalEndHeader, journal_end.c_str());
  if (s == NATS_OK) s = natsMsgHeader_Set(m, kLastMessageHeader, last_message.c_str());
  jsPubOptions po;
  jsPubOptions_Init(&po);
  po.MaxWait = options_.ack_timeout_ms;
  jsPubAck* ack = nullptr;
  jsErrCode jerr = static_cast<jsErrCode>(0);
  if (s == NATS_OK) s = js_PublishMsg(&ack, client_->jetstream(), m, &po, &jerr);
  natsMsg_Destroy(m);
  if (s == NATS_OK) {
    *sequence = static_cast<std::int64_t>(ack->Sequence);
    jsPubAck_Destroy(ack);
    return Sent::kStored;
  }
  if (jerr == JSStreamWrongLastSequenceErr) return Sent::kMoved;
  *error = NatsStatus(("stream " + options_.stream + ": batch " + batch.id + " not stored").c_str(),
                      s, jerr);
  return Sent::kFailed;
}

core::Status StreamJournal::Reconcile() {
  auto newest = ReadNewest(client_->jetstream(), options_);
  if (!newest.ok()) return newest.status();
  const std::int64_t seq = newest.value().first.sequence;
  const std::string& msg_id = newest.value().second;
  const auto by_id = [&](const Batch& b) { return b.id == msg_id; };
  const auto it = std::find_if(pending_.begin(), pending_.end(), by_id);
  if (it != pending_.end()) {  // an earlier attempt landed: it and those before it are stored
    const auto stored = it + 1;
    for (auto b = pending_.begin(); b != stored; ++b) Stored(std::move(*b), b == it ? seq : 0);
    pending_.erase(pending_.begin(), stored);
    return core::Status::Ok();
  }
  // The stream ends before batches it acknowledged (servers killed before their stores reached
  // the disk can elect a leader without them): those are sent again, under new ids.
  const auto acked = std::find_if(acked_.begin(), acked_.end(), by_id);
  const bool all_lost = seq == 0 && retained_all_;
  if (acked == acked_.end() && !all_lost) {
    return core::FailedPrecondition("stream " + options_.stream + " was appended to by another " +
                                    "writer (message " + std::to_string(seq) + ", id '" + msg_id +
                                    "'): this slamd may no longer write it");
  }
  const auto lost = all_lost ? acked_.begin() : acked + 1;
  lost_batches_ += acked_.end() - lost;
  for (auto b = std::make_reverse_iterator(acked_.end()); b != std::make_reverse_iterator(lost);
       ++b) {
    b->id += "-again" + std::to_string(lost_batches_);
    pending_.push_front(std::move(*b));
  }
  acked_.erase(lost, acked_.end());
  end_.sequence = seq;
  return core::Status::Ok();
}

core::Status StreamJournal::Commit() {
  std::lock_guard lock(commit_mutex_);
  {
    std::lock_guard stage(stage_mutex_);
    CutBatchesLocked();
  }
  int reconciles = 0;
  while (!pending_.empty()) {
    core::Status error;
    std::int64_t sequence = 0;
    switch (Publish(pending_.front(), &sequence, &error)) {
      case Sent::kStored:
        Stored(std::move(pending_.front()), sequence);
        pending_.pop_front();
        break;
      case Sent::kMoved:
        if (++reconciles > 8) {
          return core::Unavailable("stream " + options_.stream +
                                   " keeps refusing appends after its last sequence moved");
        }
        SLAMD_RETURN_IF_ERROR(Reconcile());
        break;
      case Sent::kFailed:
        return error;
    }
  }
  return core::Status::Ok();
}

StreamPosition StreamJournal::stream_end() const {
  std::lock_guard lock(commit_mutex_);
  return end_;
}
std::int64_t StreamJournal::pending_bytes() const {
  std::int64_t n = 0;
  {
    std::lock_guard lock(stage_mutex_);
    n += static_cast<std::int64_t>(staged_.size());
  }
  std::lock_guard lock(commit_mutex_);
  for (const Batch& b : pending_) n += static_cast<std::int64_t>(b.bytes.size());
  return n;
}
std::int64_t StreamJournal::batches_published() const {
  std::lock_guard lock(commit_mutex_);
  return batches_published_;
}

}  // namespace slamd::server
