// A message too large for one NATS message (the server's max_payload, 1 MiB by default: a map
// shard's summary on a few hundred shared variables is larger) travels in chunks: each is framed
// (relay_bus.h's Frame) with the tag "<sender>/<number>/<index>/<count>", and the receiver puts
// the chunks of a sender's message back together. NATS core subjects deliver at most once and in
// order per publisher: a message with a chunk missing is dropped when the sender's next one
// starts (as a lost message would be).
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/base/status.h"

namespace slamd::server {

// The chunks of message `number` of `sender` (1..64 chars, no '/'), at most chunk_bytes of
// `bytes` each (> 0); one chunk for an empty message.
std::vector<std::vector<std::uint8_t>> SplitIntoChunks(const std::string& sender,
                                                       std::uint64_t number,
                                                       std::span<const std::uint8_t> bytes,
                                                       std::size_t chunk_bytes);

class ChunkAssembler {
 public:
  // One chunk: the whole message once it completes one; nullopt while it waits for more;
  // InvalidArgument (naming what is wrong) for a payload that is not a chunk. A chunk of a
  // newer message from the same sender drops what was gathered of the older one.
  core::Result<std::optional<std::vector<std::uint8_t>>> Add(std::span<const std::uint8_t> chunk);

  // Messages dropped incomplete (a chunk was lost); read from any thread (status_t).
  std::int64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  struct Partial {
    std::uint64_t number = 0;
    std::vector<std::vector<std::uint8_t>> parts;  // by index
    std::vector<bool> got;                         // by index
    int have = 0;
  };
  std::map<std::string, Partial> by_sender_;
  std::atomic<std::int64_t> dropped_{0};
};

}  // namespace slamd::server
