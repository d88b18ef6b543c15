#include "server/replication/leader_lease.h"

#include <nats/nats.h>

#include "core/base/param_check.h"

namespace slamd::server {

core::Status LeaderLeaseOptions::Validate() const {
  SLAMD_RETURN_IF_ERROR(nats.Validate());
  if (!IsNatsName(bucket)) {
    return core::InvalidArgument("LeaderLeaseOptions::bucket = '" + bucket +
                                 "'; violates [A-Za-z0-9_-]+");
  }
  if (!IsNatsName(key)) {
    return core::InvalidArgument("LeaderLeaseOptions::key = '" + key +
                                 "'; violates [A-Za-z0-9_-]+");
  }
  SLAMD_PARAM_CHECK(LeaderLeaseOptions, ttl_ms, >=, 100);
  SLAMD_PARAM_CHECK(LeaderLeaseOptions, ttl_ms, <=, 60000);
  SLAMD_PARAM_CHECK(LeaderLeaseOptions, replicas, >=, 1);
  SLAMD_PARAM_CHECK(LeaderLeaseOptions, replicas, <=, 5);
  if (holder.empty()) return core::InvalidArgument("LeaderLeaseOptions::holder: empty");
  return core::Status::Ok();
}

core::Result<std::unique_ptr<LeaderLease>> LeaderLease::Open(const LeaderLeaseOptions& options) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  core::Result<std::unique_ptr<NatsClient>> client = NatsClient::Connect(options.nats);
  if (!client.ok()) return client.status();
  kvStore* kv = nullptr;
  natsStatus s = js_KeyValue(&kv, client.value()->jetstream(), options.bucket.c_str());
  if (s == NATS_NOT_FOUND) {
    kvConfig cfg;
    kvConfig_Init(&cfg);
    cfg.Bucket = options.bucket.c_str();
    cfg.History = 1;
    cfg.TTL = std::int64_t{options.ttl_ms} * 1000000;  // [ns], as the stream's MaxAge
    cfg.Replicas = options.replicas;
    cfg.StorageType = js_FileStorage;
    s = js_CreateKeyValue(&kv, client.value()->jetstream(), &cfg);
  }
  if (s != NATS_OK) {
    return NatsStatus(("cannot open the lease bucket " + options.bucket).c_str(), s);
  }
  return std::unique_ptr<LeaderLease>(new LeaderLease(options, std::move(client).value(), kv));
}

LeaderLease::~LeaderLease() { kvStore_Destroy(kv_); }

core::Result<bool> LeaderLease::TryAcquire() {
  if (held_) return true;
  std::uint64_t rev = 0;
  Clock::time_point t = Clock::now();
  natsStatus s = kvStore_CreateString(&rev, kv_, options_.key.c_str(), options_.holder.c_str());
  if (s == NATS_ERR) {
    // Refused because the key exists (JetStream's wrong-last-sequence). The client then looks
    // for a release marker with a direct get, which any replica answers: one that has not
    // applied a release yet makes a free lease look held (a hand-over right after a release
    // failed so). The stream leader decides: a released lease is taken by a write on its
    // marker's revision, refused in turn if someone took it in between.
    std::string holder;
    SLAMD_RETURN_IF_ERROR(ReadLast(&holder, &rev));
    if (!holder.empty()) return false;
    t = Clock::now();
    s = kvStore_UpdateString(&rev, kv_, options_.key.c_str(), options_.holder.c_str(), rev);
  }
  if (s == NATS_OK) {
    held_ = true;
    revision_ = rev;
    renewed_ = t;
    return true;
  }
  if (s == NATS_ERR) return false;
  return NatsStatus(("cannot take the lease " + options_.bucket + "/" + options_.key).c_str(), s);
}

core::Status LeaderLease::Renew() {
  if (!held_) return core::FailedPrecondition("the lease is not held");
  std::uint64_t rev = 0;
  const Clock::time_point t = Clock::now();
  const natsStatus s =
      kvStore_UpdateString(&rev, kv_, options_.key.c_str(), options_.holder.c_str(), revision_);
  if (s == NATS_OK) {
    revision_ = rev;
    renewed_ = t;
    return core::Status::Ok();
  }
  const bool lapsed = Clock::now() - renewed_ >= std::chrono::milliseconds(options_.ttl_ms);
  if (s == NATS_ERR || lapsed) {
    held_ = false;
    return core::FailedPrecondition("lost the lease " + options_.bucket + "/" + options_.key +
                                    (s == NATS_ERR
                                         ? ": someone else wrote it"
                                         : ": not renewed for " + std::to_string(options_.ttl_ms) +
                                               " ms (" + natsStatus_GetText(s) + ")"));
  }
  return NatsStatus("cannot renew the lease", s);
}

core::Status LeaderLease::Release() {
  if (!held_) return core::Status::Ok();
  held_ = false;
  return NatsStatus("cannot release the lease", kvStore_Delete(kv_, options_.key.c_str()));
}

// Read through the stream leader's get API, not kvStore_Get: the bucket allows direct gets,
// which any replica answers, so a follower that has not applied the latest write yet would say
// nobody holds a lease that was just taken.
core::Status LeaderLease::ReadLast(std::string* holder, std::uint64_t* revision) {
  natsMsg* msg = nullptr;
  const std::string stream = "KV_" + options_.bucket;
  const std::string subject = "$KV." + options_.bucket + "." + options_.key;
  const natsStatus s = js_GetLastMsg(&msg, client_->jetstream(), stream.c_str(), subject.c_str(),
                                     nullptr, nullptr);
  holder->clear();
  *revision = 0;
  if (s == NATS_NOT_FOUND) return core::Status::Ok();
  if (s != NATS_OK) return NatsStatus("cannot read the lease", s);
  const char* operation = nullptr;  // "DEL" or "PURGE" for a released lease
  const bool removed = natsMsgHeader_Get(msg, "KV-Operation", &operation) == NATS_OK;
  if (!removed) holder->assign(natsMsg_GetData(msg), natsMsg_GetDataLength(msg));
  *revision = natsMsg_GetSequence(msg);
  natsMsg_Destroy(msg);
  return core::Status::Ok();
}

core::Result<std::string> LeaderLease::Holder() {
  std::string holder;
  std::uint64_t revision = 0;
  SLAMD_RETURN_IF_ERROR(ReadLast(&holder, &revision));
  return holder;
}

}  // namespace slamd::server
