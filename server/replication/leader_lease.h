// LeaderLease: who leads a replicated pair, as a key in a NATS JetStream key-value bucket whose
// entries expire after ttl_ms (the bucket's TTL). Taking the lease creates the key (refused while
// it exists); the holder rewrites it every ttl_ms / 4 with the revision it last wrote (refused
// if anyone else wrote since). A holder that dies stops rewriting, the key expires and a standby's
// next TryAcquire succeeds; a holder that cannot rewrite it for ttl_ms must assume it lost it.
// The lease says who should lead; the replicated journal's expected-last-sequence check
// (stream_journal.h) is what stops a deposed leader from writing.
//
// Thread safety: calls from one thread at a time (the daemon's estimator thread until it leads,
// then its slamd-lease thread); held() and TryAcquire() of a held lease from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "core/base/status.h"
#include "server/replication/nats_client.h"

typedef struct __kvStore kvStore;

namespace slamd::server {

struct LeaderLeaseOptions {
  NatsOptions nats = {};
  std::string bucket = "SLAMD_LEADER";  // [A-Za-z0-9_-]+
  std::string key = "leader";
  int ttl_ms = 1000;   // the lease lapses this long after the last rewrite [ms]; 100..60000
  int replicas = 3;    // copies of the bucket; 1..5
  std::string holder;  // who asks (the data directory's id): the key's value

  core::Status Validate() const;
};

class LeaderLease {
 public:
  using Clock = std::chrono::steady_clock;

  // Connects and creates the bucket when it does not exist.
  static core::Result<std::unique_ptr<LeaderLease>> Open(const LeaderLeaseOptions& options);
  ~LeaderLease();
  LeaderLease(const LeaderLease&) = delete;
  LeaderLease& operator=(const LeaderLease&) = delete;

  // Takes the lease if nobody holds it: true when this process holds it now.
  core::Result<bool> TryAcquire();
  // Rewrites the lease (due every ttl_ms / 4). Ok while held; FailedPrecondition once it is
  // lost (someone else wrote it, or no rewrite succeeded for ttl_ms); Unavailable for a failed
  // rewrite while still within ttl_ms of the last good one.
  core::Status Renew();
  // Deletes the key (a clean stop hands over at once); nothing if not held.
  core::Status Release();
  // The current holder's id ("" when none), read from the bucket.
  core::Result<std::string> Holder();

  // Also read by other threads (the daemon's estimator thread while slamd-lease renews).
  bool held() const { return held_; }

 private:
  LeaderLease(const LeaderLeaseOptions& options, std::unique_ptr<NatsClient> client, kvStore* kv)
      : options_(options), client_(std::move(client)), kv_(kv) {}

  // The key's last entry as the stream leader has it: its holder ("" when released or never
  // written) and its revision (0 when never written).
  core::Status ReadLast(std::string* holder, std::uint64_t* revision);

  const LeaderLeaseOptions options_;
  std::unique_ptr<NatsClient> client_;
  kvStore* kv_ = nullptr;
  std::atomic<bool> held_{false};
  std::uint64_t revision_ = 0;
  Clock::time_point renewed_;  // last successful write
};

}  // namespace slamd::server
