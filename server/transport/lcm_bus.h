// LcmBus: a Bus over LCM (lcm.h stays in lcm_bus.cc).
//
// URLs (LCM 1.3.1): "udpm://239.255.76.67:7667?ttl=0" (UDP multicast between processes on one
// host; ttl=1 reaches the LAN), "memq://" (one process; each LcmBus is its own bus),
// "file:///path?mode=w" / "file:///path?speed=0" (write / read an event log).
// udpm needs a multicast route; without one LCM cannot start and Create says how to add it.
// Tests never use udpm outside a private network namespace (scripts/netns-run).
//
// Queues: LCM buffers received messages per subscription and silently drops what exceeds the
// capacity (30 by default). Every subscription here gets `queue_capacity` instead, so a burst
// waits in memory (up to capacity x message size) rather than vanishing.
//
// Threading: as Bus. LCM allows one thread in HandleOnce; Publish is thread-safe.
#pragma once

#include <memory>
#include <string>

#include "server/transport/bus.h"

namespace slamd::server {

struct LcmBusParams {
  // LCM provider URL (see above). Required: an empty URL would silently fall back to
  // $LCM_DEFAULT_URL or LCM's multicast default.
  std::string url;
  // Messages buffered per subscription before LCM drops; >= 1. 0 (LCM's "unbounded") is not
  // allowed: memory must stay bounded.
  int queue_capacity = 10000;
  // udpm:// only: the socket receive buffer asked for when the URL names no recv_buf_size.
  // The kernel default (~200 kB, ~160 small datagrams) overflows when a client streams faster
  // than an update takes, and a datagram dropped there is lost without a trace. The kernel caps
  // the request at net.core.rmem_max. >= 0; 0 = the kernel default.
  int udpm_receive_buffer_bytes = 4 << 20;

  core::Status Validate() const;
};

class LcmBus final : public Bus {
 public:
  // InvalidArgument for bad params; IoError when LCM cannot start on the URL (the message
  // carries the multicast-route fix for udpm://).
  static core::Result<std::unique_ptr<LcmBus>> Create(const LcmBusParams& params);
  ~LcmBus() override;
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  core::Status Publish(std::string_view channel, std::span<const std::uint8_t> bytes) override;
  // channel_regex uses LCM's (GLib/PCRE) regex syntax, matched against the whole channel name.
  core::Result<Subscription> Subscribe(std::string_view channel_regex,
                                       MessageCallback callback) override;
  // Dispatches at most one message: returns 1 or 0 (timeout). Waits in ppoll(2) on LCM's file
  // descriptor (lcm_handle_timeout counts whole milliseconds), then lcm_handle_timeout(0).
  core::Result<int> HandleFor(std::chrono::microseconds timeout) override;

  const std::string& url() const;

 private:
  struct Impl;
  explicit LcmBus(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_;  // shared (weakly) with Subscription handles
};

}  // namespace slamd::server
