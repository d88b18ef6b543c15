// Bus: the message transport slamd talks through, as raw bytes on named channels.
//
// Implementations: LcmBus (LCM: udpm:// between processes, memq:// in one process, file:// logs)
// and InProcessBus (no threads, deterministic, for tests). Typed access (decode, encode) is in
// typed_subscribe.h; this interface never sees message types.
//
// Threading (the LCM model): Publish may be called from any thread. Callbacks run only inside
// HandleOnce, on the thread that calls it, and only one thread may call HandleOnce at a time.
// Subscribe and Subscription::Unsubscribe must not run concurrently with HandleOnce and must not
// be called from inside a callback.
//
// Delivery: a message reaches the subscriptions that exist when it is published, in publish
// order per channel (subscribe before the first message you need; LCM drops messages that have
// no subscriber).
//
// Errors: callbacks must not throw (they may run under C frames). If one does, the bus catches
// it, keeps going, and the next HandleOnce returns the error (FailedPrecondition naming the
// channel), so a faulty handler is reported, not fatal.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "core/base/status.h"

namespace slamd::server {

// LCM's own limit on channel names (LCM_MAX_CHANNEL_NAME_LENGTH); every Bus enforces it so that
// code tested on InProcessBus behaves the same on LcmBus.
inline constexpr int kMaxChannelNameLength = 63;

// Receives one message: the channel it arrived on and its bytes (valid only during the call).
using MessageCallback =
    std::function<void(std::string_view channel, std::span<const std::uint8_t> bytes)>;

// A live subscription. Move-only; destroying it (or calling Unsubscribe) stops the callbacks.
// Safe to destroy after its bus is gone (it then does nothing).
class [[nodiscard]] Subscription {
 public:
  Subscription() = default;  // inactive
  // For Bus implementations: `unsubscribe` is called once, by Unsubscribe or the destructor.
  explicit Subscription(std::function<void()> unsubscribe) : unsubscribe_(std::move(unsubscribe)) {}
  Subscription(Subscription&& other) noexcept;
  Subscription& operator=(Subscription&& other) noexcept;
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;
  ~Subscription() { Unsubscribe(); }

  void Unsubscribe();
  bool active() const { return static_cast<bool>(unsubscribe_); }

 private:
  std::function<void()> unsubscribe_;
};

class Bus {
 public:
  virtual ~Bus() = default;

  // Sends `bytes` on `channel` (1..kMaxChannelNameLength chars). Thread-safe. InvalidArgument
  // for a bad channel name, IoError when the transport refuses.
  virtual core::Status Publish(std::string_view channel, std::span<const std::uint8_t> bytes) = 0;

  // Calls `callback` for every message whose channel fully matches `channel_regex` (a plain
  // channel name is a regex that matches itself; "SLAMD_.*" matches a prefix). InvalidArgument
  // for an empty or malformed pattern.
  virtual core::Result<Subscription> Subscribe(std::string_view channel_regex,
                                               MessageCallback callback) = 0;

  // Waits up to `timeout` (>= 0; 0 = poll) for messages and dispatches at least one if any
  // arrives. Returns how many messages were dispatched (0 on timeout), or an error:
  // InvalidArgument for a negative timeout, IoError when the transport fails,
  // FailedPrecondition when a callback threw during this call. Microseconds, so that a paced
  // sender can wait for its next slot and for replies in one call (slamctl replay --rate).
  virtual core::Result<int> HandleFor(std::chrono::microseconds timeout) = 0;
  // HandleFor in milliseconds.
  core::Result<int> HandleOnce(int timeout_ms) {
    return HandleFor(std::chrono::milliseconds(timeout_ms));
  }
};

// InvalidArgument unless 1 <= size <= kMaxChannelNameLength.
core::Status CheckChannelName(std::string_view channel);

}  // namespace slamd::server
