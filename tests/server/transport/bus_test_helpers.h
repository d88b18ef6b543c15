// Helpers for Bus tests: a named bus factory (for value-parameterised suites), a loop that
// handles until a condition holds, byte literals.
#pragma once

#include <chrono>
#include <functional>
#include <initializer_list>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "server/transport/bus.h"

namespace slamd::server::testing {

struct BusFactory {
  std::string name;
  std::function<std::unique_ptr<Bus>()> make;
};
inline void PrintTo(const BusFactory& f, std::ostream* os) { *os << f.name; }

struct Received {
  std::string channel;
  std::vector<std::uint8_t> bytes;
};

// Calls HandleOnce until `done` or `max_ms` elapsed; returns the last HandleOnce error (or ok).
inline core::Status HandleUntil(Bus& bus, const std::function<bool()>& done, int max_ms = 2000) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(max_ms);
  core::Status last;
  while (!done() && std::chrono::steady_clock::now() < deadline) {
    auto r = bus.HandleOnce(10);
    if (!r.ok()) last = r.status();
  }
  return last;
}

inline std::vector<std::uint8_t> Bytes(std::initializer_list<int> v) {
  std::vector<std::uint8_t> out;
  for (int b : v) out.push_back(static_cast<std::uint8_t>(b));
  return out;
}

}  // namespace slamd::server::testing
