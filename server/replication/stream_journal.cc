#include "server/replication/stream_journal.h"

#include <nats/nats.h>

#include <algorithm>
#include <charconv>
#include <random>

#include "core/base/param_check.h"

namespace slamd::server {
namespace {

constexpr const char* kStreamOffsetHeader = "Slamd-Stream-Offset";
constexpr const char* kJournalEndHeader = "Slamd-Journal-End";
// Acknowledged batches kept to send again should the stream lose them [bytes].
constexpr std::int64_t kRetainBytes = std::int64_t{64} << 20;
constexpr size_t kFollowPoints = 4096;

// 16 hex digits, different for every writer (pid and a random device).
std::string NewWriterId() {
  std::random_device rd;
  const std::uint64_t v = (std::uint64_t{rd()} << 32) ^ rd() ^ std::uint64_t(::getpid());
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// The newest message of the stream (its position) and its Nats-Msg-Id.
core::Result<std::pair<StreamPosition, std::string>> ReadNewest(jsCtx* js,
                                                                const StreamJournalOptions& o) {
  jsOptions jo = NatsWait(o.ack_timeout_ms);
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

std::int64_t NumberHeader(natsMsg* msg, const char* key, std::int64_t absent) {
  const char* v = nullptr;
  if (natsMsgHeader_Get(msg, key, &v) != NATS_OK || v == nullptr) return absent;
  std::int64_t n = 0;
  const char* end = v + std::strlen(v);
  if (std::from_chars(v, end, n).ptr != end) return absent;
  return n;
}

StreamPosition PositionOf(natsMsg* msg) {
  StreamPosition p{.sequence = static_cast<std::int64_t>(natsMsg_GetSequence(msg)),
                   .stream_offset = NumberHeader(msg, kStreamOffsetHeader, -1),
                   .payload_bytes = natsMsg_GetDataLength(msg),
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
  core::Result<StreamRange> range =
      OpenStream(js, {.name = options.stream,
                      .subject = options.subject,
                      .replicas = options.replicas,
                      .wait_ms = std::max(options.ack_timeout_ms, kNatsAdminWaitMs)});
  if (!range.ok()) return range.status();
  const std::int64_t last = range.value().last;
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
      cut_{.last_message = end.last_message, .journal_end = end.journal_end},
      stream_bytes_(end.stream_offset >= 0 ? end.stream_offset + end.payload_bytes : 0),
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
    Batch batch{.id = writer_id_ + "-" + std::to_string(next_batch_++),
                .stream_offset = stream_bytes_,
                .whole_start = cut_whole_,
                .last_message_before = cut_.last_message};
    size_t end = begin;
    while (next < marks_.size() && marks_[next].end - begin <= max) {  // whole records
      end = marks_[next].end;
      // A message's record moves last_message on; any other leaves it.
      if (marks_[next].position.last_message == cut_.last_message) ++batch.others;
      cut_ = marks_[next].position;
      ++next;
    }
    cut_whole_ = end != begin;  // else it ends inside a record longer than what is left
    if (end == begin) end = std::min(staged_.size(), begin + max);  // a longer record, cut
    batch.bytes = staged_.substr(begin, end - begin);
    stream_bytes_ += static_cast<std::int64_t>(batch.bytes.size());
    batch.end = cut_;
    pending_.push_back(std::move(batch));
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
  if (sequence > 0 && batch.whole_start) {
    starts_.push_back({.point = {.sequence = sequence, .stream_offset = batch.stream_offset},
                       .last_message_before = batch.last_message_before,
                       .others_before = others_acked_});
    if (starts_.size() > kFollowPoints) starts_.pop_front();
  }
  others_acked_ += batch.others;
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
  int jerr = 0;
  core::Result<std::int64_t> stored =
      PublishToStream(client_->jetstream(),
                      {.subject = options_.subject,
                       .payload = batch.bytes,
                       .headers = {{"Nats-Msg-Id", batch.id},
                                   {"Nats-Expected-Last-Sequence", std::to_string(end_.sequence)},
                                   {kSourceHeader, options_.source},
                                   {kStreamOffsetHeader, std::to_string(batch.stream_offset)},
                                   {kJournalEndHeader, std::to_string(batch.end.journal_end)},
                                   {kLastMessageHeader, std::to_string(batch.end.last_message)}}},
                      options_.ack_timeout_ms,
                      "stream " + options_.stream + ": batch " + batch.id + " not stored", &jerr);
  if (stored.ok()) {
    *sequence = stored.value();
    return Sent::kStored;
  }
  if (jerr == JSStreamWrongLastSequenceErr) return Sent::kMoved;
  *error = stored.status();
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
    others_acked_ -= b->others;  // counted again when stored again
    pending_.push_front(std::move(*b));
  }
  acked_.erase(lost, acked_.end());
  end_.sequence = seq;
  // Where readers may start: not in messages the stream no longer has.
  while (!starts_.empty() && starts_.back().point.sequence > seq) starts_.pop_back();
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

core::Result<FollowPoint> StreamJournal::FollowPointFor(std::int64_t last_message) const {
  std::lock_guard lock(commit_mutex_);
  for (auto s = starts_.rbegin(); s != starts_.rend(); ++s) {
    if (s->last_message_before <= last_message) {
      FollowPoint p = s->point;
      p.skip = others_acked_ - s->others_before;
      return p;
    }
  }
  return core::NotFound(
      "stream " + options_.stream + ": no message of the newest " + std::to_string(starts_.size()) +
      " begins with a record after messages up to " + std::to_string(last_message) + " only");
}

}  // namespace slamd::server
