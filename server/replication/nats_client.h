// NatsClient: one connection to a NATS cluster with its JetStream context (libnats, the C
// client), for the replicated journal. It reconnects by itself (forever, every
// reconnect_wait_ms, trying each server), buffering what is published meanwhile; calls made
// while it is disconnected time out and return Unavailable.
//
// Errors from libnats become a Status naming the call and what NATS said
// (NatsStatus): NATS_TIMEOUT, NATS_NO_SERVER and a closed or reconnecting connection are
// Unavailable (the caller retries), JetStream API errors keep their code in the message.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/base/status.h"

typedef struct __natsConnection natsConnection;
typedef struct __jsCtx jsCtx;
typedef struct __natsSubscription natsSubscription;
struct jsOptions;

namespace slamd::server {

// How long requests that create or look up streams and consumers wait: a replicated stream's or
// consumer's RAFT group takes longer to form than an append to be acknowledged [ms].
inline constexpr int kNatsAdminWaitMs = 5000;

struct NatsOptions {
  // The servers of the cluster, e.g. {"nats://127.0.0.1:4222", "nats://127.0.0.1:4223"}.
  std::vector<std::string> servers;
  int connect_timeout_ms = 2000;  // per server, at the first connection [ms]
  int reconnect_wait_ms = 100;    // between attempts once connected [ms]

  core::Status Validate() const;  // "NatsOptions::servers: empty", ...
};

// Whether `name` may name a stream, a key-value bucket or a key: [A-Za-z0-9_-]+.
bool IsNatsName(const std::string& name);

// Whether `subject` is a literal subject: IsNatsName tokens joined by dots (no wildcards).
bool IsNatsSubject(const std::string& subject);

// "nats://a:4222,nats://b:4222" -> its entries (empty ones dropped).
std::vector<std::string> SplitServers(const std::string& comma_separated);

// The status of a libnats call: Ok for NATS_OK, else Unavailable (time-outs, no server, lost
// connection) or IoError, with `what` and the library's text (and the JetStream error code when
// it is not 0).
core::Status NatsStatus(const char* what, int nats_status, int js_error = 0);

// Options of a JetStream call (libnats) that waits up to wait_ms for its answer.
jsOptions NatsWait(int wait_ms);

// A JetStream stream capturing exactly one subject, with file storage: opened, or created with
// `replicas` copies (and a `duplicate_window_s` window in which a message id is stored once)
// when it does not exist. FailedPrecondition when it exists with another subject.
struct StreamSpec {
  std::string name;
  std::string subject;
  int replicas = 3;
  int duplicate_window_s = 120;
  int wait_ms = kNatsAdminWaitMs;
};
struct StreamRange {
  std::int64_t first = 0;  // the oldest message kept (0: empty)
  std::int64_t last = 0;   // the newest (0: never written)
  std::int64_t bytes = 0;  // kept, as the servers count them
};
core::Result<StreamRange> OpenStream(jsCtx* js, const StreamSpec& spec);

// A message for a JetStream stream: its subject, payload and headers.
struct StreamMessage {
  std::string subject;
  std::string_view payload;
  std::vector<std::pair<const char*, std::string>> headers;
};
// Publishes `message`, waiting up to wait_ms for the stream's acknowledgement: the sequence the
// stream stored it at, or an error naming `what` (*js_error: JetStream's error code, 0 if none).
core::Result<std::int64_t> PublishToStream(jsCtx* js, const StreamMessage& message, int wait_ms,
                                           const std::string& what, int* js_error);

// Deletes the messages of stream `name` before message `sequence` (a truncation).
core::Status PurgeStreamBefore(jsCtx* js, const std::string& name, std::int64_t sequence,
                               int wait_ms);

class NatsClient {
 public:
  // Connects to one of the servers (Unavailable naming them when none answers) and opens the
  // JetStream context.
  static core::Result<std::unique_ptr<NatsClient>> Connect(const NatsOptions& options);
  ~NatsClient();
  NatsClient(const NatsClient&) = delete;
  NatsClient& operator=(const NatsClient&) = delete;

  jsCtx* jetstream() const { return js_; }

  // Core NATS, at most once (map shards' summaries): publishes `bytes` on `subject`;
  // InvalidArgument when they exceed the server's max_payload.
  core::Status Publish(const std::string& subject, std::span<const std::uint8_t> bytes);
  // Calls `on_message` on libnats' delivery thread for every message on `subject` until this
  // client is destroyed.
  using MessageCallback = std::function<void(std::span<const std::uint8_t> payload)>;
  core::Status Subscribe(const std::string& subject, MessageCallback on_message);

 private:
  NatsClient(natsConnection* nc, jsCtx* js);
  natsConnection* nc_ = nullptr;
  jsCtx* js_ = nullptr;
  struct Subscription;
  std::vector<std::unique_ptr<Subscription>> subscriptions_;
};

}  // namespace slamd::server
