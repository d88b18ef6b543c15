// LcmClient: slamctl's connection to slamd. A thin layer over a server::Bus (LcmBus for a URL,
// any Bus in tests) that owns its subscriptions, decodes typed messages, counts undecodable ones
// and handles messages until a condition holds or a deadline passes.
//
//   auto client = LcmClient::Create(url).value();    // "" = LCM's default URL (below)
//   client->Subscribe<slamd::status_t>("SLAMD_STATUS", [&](const slamd::status_t& s) { ... });
//   client->Publish("SLAMD_QUERY", query);
//   bool got = client->HandleUntil([&] { return done; }, 2.0);
//
// Threading: one thread (callbacks run inside Handle*/HandleUntil on the calling thread), except
// Publish, which is thread-safe as in LCM. Never throws; callbacks must not throw either (an
// exception from one is turned into a decode error by server::Subscribe and counted).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "server/transport/bus.h"
#include "server/transport/typed_subscribe.h"

namespace slamd::clients {

// LCM's default URL as lcm_create(NULL) picks it: $LCM_DEFAULT_URL when set and non-empty, else
// "udpm://239.255.76.67:7667?ttl=0" (LCM 1.3.1's built-in default).
std::string DefaultLcmUrl();

class LcmClient {
 public:
  // An LcmBus on `url` ("" = DefaultLcmUrl()). IoError when LCM cannot start (for udpm the
  // message says how to add the multicast route), InvalidArgument for a bad URL.
  static core::Result<std::unique_ptr<LcmClient>> Create(const std::string& url);
  // Over an existing bus (tests: InProcessBus or memq://).
  explicit LcmClient(std::unique_ptr<server::Bus> bus, std::string url = "");

  const std::string& url() const { return url_; }
  // The underlying bus (tests attach a fake server to it).
  server::Bus& bus() { return *bus_; }

  // Calls on_msg(msg) for each message on `channel_regex` that decodes as Msg; other bytes are
  // counted in decode_errors() (last_error() says why). The subscription lives as long as this.
  template <typename Msg>
  core::Status Subscribe(const std::string& channel_regex, std::function<void(const Msg&)> on_msg) {
    core::Result<server::Subscription> sub = server::Subscribe<Msg>(
        *bus_, channel_regex,
        [on_msg = std::move(on_msg)](std::string_view, const Msg& m) { on_msg(m); },
        [this](std::string_view channel, const core::Status& error) {
          ++decode_errors_;
          last_error_ = std::string(channel) + ": " + error.message();
        });
    if (!sub.ok()) return sub.status();
    subscriptions_.push_back(std::move(sub).value());
    return core::Status::Ok();
  }

  template <typename Msg>
  core::Status Publish(const std::string& channel, const Msg& msg) {
    return server::Publish(*bus_, channel, msg);
  }
  core::Status PublishBytes(const std::string& channel, std::span<const std::uint8_t> bytes) {
    return bus_->Publish(channel, bytes);
  }

  // Waits up to timeout_ms for messages and dispatches what arrives (see Bus::HandleOnce):
  // the number dispatched, 0 on timeout.
  core::Result<int> Handle(int timeout_ms) { return bus_->HandleOnce(timeout_ms); }
  // Dispatches everything already received, without waiting. The number dispatched.
  core::Result<int> Drain();
  // Handles messages until done() is true (checked before the first wait and after every
  // dispatch) or timeout_s passes (< 0: no limit). Returns done(); an error of the bus ends it.
  core::Result<bool> HandleUntil(const std::function<bool()>& done, double timeout_s);

  std::int64_t decode_errors() const { return decode_errors_; }
  const std::string& last_error() const { return last_error_; }

 private:
  std::unique_ptr<server::Bus> bus_;
  std::string url_;
  std::vector<server::Subscription> subscriptions_;
  std::int64_t decode_errors_ = 0;
  std::string last_error_;
};

}  // namespace slamd::clients
