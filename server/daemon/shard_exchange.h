// A map shard's link to the other shards (docs/SCALING.md): the Daemon's state for
// daemon_shards.cc. The NATS connection, the relays of the answers to forwarded queries, the
// last summary sent, and the counters status_t reports.
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "server/messages/shard_summary.h"
#include "server/replication/message_chunks.h"
#include "server/replication/nats_client.h"
#include "server/replication/relay_bus.h"

namespace slamd::server {

struct ShardExchange {
  // Summaries and forwarded queries (null: summaries on the bus, nothing forwarded).
  std::unique_ptr<NatsClient> nats;
  // shards.forward_queries: per other shard, the relay of the answers to the queries it
  // forwarded here (<subject>.<shard>.reply).
  std::map<std::string, std::unique_ptr<RelayBus>> relays;
  // When summaries last went out (steady µs), of which update, and the last one sent
  // (estimator thread).
  std::int64_t last_sent_us = 0, last_sent_sequence = -1;
  ShardSummaryMessage last_sent;
  // Over NATS a summary travels in chunks (message_chunks.h): the number of the last one sent
  // (estimator thread), and the other shards' being put together (the subscription's thread).
  std::uint64_t summaries_numbered = 0;
  ChunkAssembler summary_chunks;
  // Messages for robots another shard owns (dropped), summaries sent and their bytes, queries
  // forwarded to their owner.
  std::atomic<std::int64_t> not_owned{0}, summaries_sent{0}, summary_bytes{0};
  std::atomic<std::int64_t> queries_forwarded{0};
};

}  // namespace slamd::server
