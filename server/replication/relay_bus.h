// Map shards on different LCM buses (shards.forward_queries, docs/SCALING.md): a query for
// another shard's robot travels to its owner over NATS, and what the owner would publish in
// answer (query_reply_t, map_t pages, reject_t) travels back the same way to be published on the
// asker's bus.
//
// RelayBus is the owner's side: a Bus that only publishes, sending each message to one NATS
// subject framed with its channel's suffix (the channel less the owner's prefix, so the shard
// that publishes it puts its own prefix in front). Frame / Unframe are the framing.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "server/replication/nats_client.h"
#include "server/transport/bus.h"

namespace slamd::server {

// [tag length: 1 byte][tag][body]; tags of 1..255 bytes.
std::vector<std::uint8_t> Frame(std::string_view tag, std::span<const std::uint8_t> body);

struct Framed {
  std::string_view tag;
  std::span<const std::uint8_t> body;
};
// The parts of a framed payload (views into it); nullopt when it is too short or the tag empty.
std::optional<Framed> Unframe(std::span<const std::uint8_t> payload);

class RelayBus final : public Bus {
 public:
  // Publishes on `subject` through `nats` (not owned; outlives this); channels must start with
  // `prefix`, which is cut off.
  RelayBus(NatsClient* nats, std::string subject, std::string prefix)
      : nats_(nats), subject_(std::move(subject)), prefix_(std::move(prefix)) {}

  core::Status Publish(std::string_view channel, std::span<const std::uint8_t> bytes) override;
  // Publish-only: FailedPrecondition.
  core::Result<Subscription> Subscribe(std::string_view channel_regex,
                                       MessageCallback callback) override;
  core::Result<int> HandleFor(std::chrono::microseconds timeout) override;

 private:
  NatsClient* nats_;
  std::string subject_;
  std::string prefix_;
};

}  // namespace slamd::server
