// LcmClient (see lcm_client.h).
#include "clients/slamctl/lcm_client.h"

#include <algorithm>
#include <cstdlib>
#include <thread>

#include "server/transport/lcm_bus.h"

namespace slamd::clients {

std::string DefaultLcmUrl() {
  const char* env = std::getenv("LCM_DEFAULT_URL");
  if (env != nullptr && env[0] != '\0') return env;
  return "udpm://239.255.76.67:7667?ttl=0";
}

core::Result<std::unique_ptr<LcmClient>> LcmClient::Create(const std::string& url) {
  const std::string resolved = url.empty() ? DefaultLcmUrl() : url;
  core::Result<std::unique_ptr<server::LcmBus>> bus =
      server::LcmBus::Create(server::LcmBusParams{.url = resolved});
  if (!bus.ok()) return bus.status();
  return std::make_unique<LcmClient>(std::move(bus).value(), resolved);
}

LcmClient::LcmClient(std::unique_ptr<server::Bus> bus, std::string url)
    : bus_(std::move(bus)), url_(std::move(url)) {}

core::Result<int> LcmClient::Drain() {
  int total = 0;
  for (;;) {
    core::Result<int> n = bus_->HandleOnce(0);
    if (!n.ok()) return n.status();
    if (*n == 0) return total;
    total += *n;
  }
}

core::Result<bool> LcmClient::HandleUntil(const std::function<bool()>& done, double timeout_s) {
  using Clock = std::chrono::steady_clock;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(timeout_s < 0 ? 0.0 : timeout_s));
  while (!done()) {
    int wait_ms = 100;
    if (timeout_s >= 0) {
      const auto left =
          std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now());
      if (left.count() <= 0) return done();
      // LCM waits in whole milliseconds. The last one is spent in short naps with the incoming
      // messages handled in between, so that a deadline that is a send time (replay --rate) is
      // kept to ~50 µs, and what arrives meanwhile is timed as closely.
      if (left.count() < 1000) {
        SLAMD_RETURN_IF_ERROR(Drain().status());
        if (done()) return true;
        std::this_thread::sleep_for(
            std::chrono::microseconds(std::min<long long>(left.count(), 50)));
        continue;
      }
      wait_ms = static_cast<int>(std::min<long long>(left.count() / 1000, 100));
    }
    core::Result<int> n = bus_->HandleOnce(wait_ms);
    if (!n.ok()) return n.status();
  }
  return true;
}

}  // namespace slamd::clients
