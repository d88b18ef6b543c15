#include "server/replication/stream_snapshots.h"

#include <nats/nats.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "server/journal/crc32c.h"

namespace slamd::server {
namespace {

constexpr const char* kSnapshot = "Slamd-Snapshot";
constexpr const char* kChunk = "Slamd-Chunk";
constexpr const char* kChunks = "Slamd-Chunks";
constexpr const char* kCrc = "Slamd-Crc32c";
constexpr const char* kFollowSequence = "Slamd-Follow-Sequence";
constexpr const char* kFollowOffset = "Slamd-Follow-Offset";
constexpr const char* kFollowSkip = "Slamd-Follow-Skip";

std::string SnapshotSubject(const StreamJournalOptions& journal) {
  return journal.subject + ".snapshots";
}

std::string Header(natsMsg* m, const char* key) {
  const char* v = nullptr;
  if (natsMsgHeader_Get(m, key, &v) != NATS_OK || v == nullptr) return "";
  return v;
}

// A chunk's message, owned.
struct Chunk {
  natsMsg* msg = nullptr;
  explicit Chunk(natsMsg* m) : msg(m) {}
  Chunk(Chunk&& o) noexcept : msg(std::exchange(o.msg, nullptr)) {}
  Chunk& operator=(Chunk&&) = delete;
  ~Chunk() { natsMsg_Destroy(msg); }
};

}  // namespace

core::Result<std::unique_ptr<StreamSnapshots>> StreamSnapshots::Open(
    const StreamJournalOptions& journal, int keep) {
  SLAMD_RETURN_IF_ERROR(journal.Validate());
  if (keep < 1) {
    return core::InvalidArgument("StreamSnapshots: keep = " + std::to_string(keep) +
                                 "; violates >= 1");
  }
  core::Result<std::unique_ptr<NatsClient>> client = NatsClient::Connect(journal.nats);
  if (!client.ok()) return client.status();
  const core::Result<StreamRange> range = OpenStream(
      client.value()->jetstream(), {.name = StreamName(journal.stream),
                                    .subject = SnapshotSubject(journal),
                                    .replicas = journal.replicas,
                                    .wait_ms = std::max(journal.ack_timeout_ms, kNatsAdminWaitMs)});
  if (!range.ok()) return range.status();
  return std::unique_ptr<StreamSnapshots>(
      new StreamSnapshots(journal, keep, std::move(client).value()));
}

core::Status StreamSnapshots::Put(const StreamSnapshot& snapshot) {
  const auto max = static_cast<size_t>(journal_.max_batch_bytes);
  const size_t chunks = std::max<size_t>(1, (snapshot.bytes.size() + max - 1) / max);
  const std::string offset = std::to_string(snapshot.journal_offset);
  const std::string crc = std::to_string(MaskCrc32c(Crc32c(snapshot.bytes)));
  std::int64_t first_chunk = 0;
  for (size_t i = 0; i < chunks; ++i) {
    const size_t begin = std::min(snapshot.bytes.size(), i * max);
    int jerr = 0;
    const core::Result<std::int64_t> stored = PublishToStream(
        client_->jetstream(),
        {.subject = SnapshotSubject(journal_),
         .payload = std::string_view(snapshot.bytes).substr(begin, max),
         .headers = {{"Nats-Msg-Id", snapshot.source + "-" + offset + "-" + std::to_string(i)},
                     {kChunk, std::to_string(i)},
                     {kSourceHeader, snapshot.source},
                     {kSnapshot, offset},
                     {kLastMessageHeader, std::to_string(snapshot.last_message)},
                     {kChunks, std::to_string(chunks)},
                     {kCrc, crc},
                     {kFollowSequence, std::to_string(snapshot.follow.sequence)},
                     {kFollowOffset, std::to_string(snapshot.follow.stream_offset)},
                     {kFollowSkip, std::to_string(snapshot.follow.skip)}}},
        journal_.ack_timeout_ms,
        "stream " + StreamName(journal_.stream) + ": snapshot at journal offset " + offset +
            " not stored",
        &jerr);
    if (!stored.ok()) return stored.status();
    if (i == 0) first_chunk = stored.value();
  }
  stored_.push_back({.first_chunk = first_chunk, .follow_sequence = snapshot.follow.sequence});
  if (stored_.size() > static_cast<size_t>(keep_)) stored_.pop_front();
  if (stored_.size() < static_cast<size_t>(keep_)) return core::Status::Ok();
  // The oldest kept is whole: what came before it in both streams goes.
  const int wait_ms = std::max(journal_.ack_timeout_ms, kNatsAdminWaitMs);
  SLAMD_RETURN_IF_ERROR(PurgeStreamBefore(client_->jetstream(), StreamName(journal_.stream),
                                          stored_.front().first_chunk, wait_ms));
  return PurgeStreamBefore(client_->jetstream(), journal_.stream, stored_.front().follow_sequence,
                           wait_ms);
}

core::Result<StreamSnapshot> StreamSnapshots::LoadEndingAt(std::int64_t last, std::int64_t* first) {
  *first = last;  // what to pass over when this one is not whole
  const std::string stream = StreamName(journal_.stream);
  const int wait_ms = std::max(journal_.ack_timeout_ms, kNatsAdminWaitMs);
  std::vector<Chunk> chunks;
  for (std::int64_t seq = last; seq >= 1; --seq) {
    jsOptions jo = NatsWait(wait_ms);
    natsMsg* m = nullptr;
    jsErrCode jerr = static_cast<jsErrCode>(0);
    const natsStatus s = js_GetMsg(&m, client_->jetstream(), stream.c_str(),
                                   static_cast<std::uint64_t>(seq), &jo, &jerr);
    if (s == NATS_NOT_FOUND) return core::NotFound("message " + std::to_string(seq) + " gone");
    if (s != NATS_OK) {
      return NatsStatus(
          ("cannot read stream " + stream + " message " + std::to_string(seq)).c_str(), s, jerr);
    }
    chunks.emplace_back(m);
    *first = seq;
    natsMsg* newest = chunks.front().msg;
    const std::int64_t index = NumberHeader(m, kChunk, -1);
    const std::int64_t expected =
        NumberHeader(newest, kChunks, -1) - static_cast<std::int64_t>(chunks.size());
    if (chunks.size() == 1 && index >= 0 && index != expected) {
      *first = std::max<std::int64_t>(1, seq - index);  // its first chunk: pass over all of it
      return core::DataLoss("the snapshot ending at message " + std::to_string(last) +
                            " lacks its last chunks (its writer stopped)");
    }
    const bool same = Header(m, kSnapshot) == Header(newest, kSnapshot) &&
                      Header(m, kSourceHeader) == Header(newest, kSourceHeader);
    if (!same || index != expected) {
      return core::DataLoss("message " + std::to_string(seq) + " is not chunk " +
                            std::to_string(expected) + " of the snapshot ending at message " +
                            std::to_string(last));
    }
    if (index == 0) break;
  }
  if (chunks.empty() || NumberHeader(chunks.back().msg, kChunk, -1) != 0) {
    return core::DataLoss("the snapshot ending at message " + std::to_string(last) +
                          " has no first chunk");
  }
  natsMsg* head = chunks.front().msg;
  StreamSnapshot out{.source = Header(head, kSourceHeader),
                     .journal_offset = NumberHeader(head, kSnapshot, -1),
                     .last_message = NumberHeader(head, kLastMessageHeader, -1),
                     .follow = {.sequence = NumberHeader(head, kFollowSequence, -1),
                                .stream_offset = NumberHeader(head, kFollowOffset, -1),
                                .skip = NumberHeader(head, kFollowSkip, -1)}};
  for (auto c = chunks.rbegin(); c != chunks.rend(); ++c) {
    out.bytes.append(natsMsg_GetData(c->msg), static_cast<size_t>(natsMsg_GetDataLength(c->msg)));
  }
  if (std::to_string(MaskCrc32c(Crc32c(out.bytes))) != Header(head, kCrc)) {
    return core::DataLoss("the snapshot ending at message " + std::to_string(last) +
                          " does not match its checksum");
  }
  if (out.journal_offset < 0 || out.last_message < 0 || out.follow.sequence < 1 ||
      out.follow.stream_offset < 0 || out.follow.skip < 0) {
    return core::DataLoss("the snapshot ending at message " + std::to_string(last) +
                          " lacks its position headers");
  }
  return out;
}

core::Result<StreamSnapshot> StreamSnapshots::LoadNewest() {
  const core::Result<StreamRange> range = OpenStream(
      client_->jetstream(), {.name = StreamName(journal_.stream),
                             .subject = SnapshotSubject(journal_),
                             .replicas = journal_.replicas,
                             .wait_ms = std::max(journal_.ack_timeout_ms, kNatsAdminWaitMs)});
  if (!range.ok()) return range.status();
  std::string passed;  // why newer ones were passed over
  for (std::int64_t last = range.value().last;
       last >= std::max<std::int64_t>(1, range.value().first);) {
    std::int64_t first = last;
    core::Result<StreamSnapshot> got = LoadEndingAt(last, &first);
    if (got.ok() || got.status().code() == core::StatusCode::kUnavailable) return got;
    passed += (passed.empty() ? "" : "; ") + got.status().message();
    last = first - 1;
  }
  return core::NotFound("stream " + StreamName(journal_.stream) + " holds no whole snapshot" +
                        (passed.empty() ? "" : " (" + passed + ")"));
}

}  // namespace slamd::server
