// InProcessBus: a Bus inside one process, with no threads and no sockets, for tests and for
// running the server in-process (integration tests, journal replay).
//
// Publish copies the message into a FIFO queue; HandleOnce dispatches every message queued when
// it starts, in publish order, to each matching subscription in subscription order, on the
// calling thread. Messages published by a callback are dispatched by the next HandleOnce, so
// delivery never recurses and a test sees exactly the order it produced. Nothing is ever dropped
// (the queue is unbounded: a test that publishes without handling grows it).
//
// Channel patterns are ECMAScript regexes that must match the whole channel name (as in LCM).
// Thread safety: as Bus (Publish from any thread; HandleOnce from one thread at a time).
#pragma once

#include <memory>

#include "server/transport/bus.h"

namespace slamd::server {

class InProcessBus final : public Bus {
 public:
  InProcessBus();
  ~InProcessBus() override;
  InProcessBus(const InProcessBus&) = delete;
  InProcessBus& operator=(const InProcessBus&) = delete;

  core::Status Publish(std::string_view channel, std::span<const std::uint8_t> bytes) override;
  core::Result<Subscription> Subscribe(std::string_view channel_regex,
                                       MessageCallback callback) override;
  // Waits (on a condition variable) up to `timeout` for the queue to become non-empty, then
  // dispatches everything queued at that moment; returns the number of messages dispatched.
  core::Result<int> HandleFor(std::chrono::microseconds timeout) override;

  // Messages published and not yet dispatched.
  int pending() const;

 private:
  struct State;
  std::shared_ptr<State> state_;  // shared (weakly) with Subscription handles
};

}  // namespace slamd::server
