#include "server/estimator/robot_registry.h"

#include <array>

namespace slamd::server {
namespace {

// Assignment order: printable letters and digits first, then every other non-zero byte.
std::array<std::uint8_t, RobotRegistry::kMaxRobots> MakeIdOrder() {
  std::array<std::uint8_t, RobotRegistry::kMaxRobots> order{};
  std::array<bool, 256> used{};
  int n = 0;
  auto add = [&](int id) {
    if (!used[id]) {
      used[id] = true;
      order[n++] = static_cast<std::uint8_t>(id);
    }
  };
  for (int c = 'a'; c <= 'z'; ++c) add(c);
  for (int c = 'A'; c <= 'Z'; ++c) add(c);
  for (int c = '0'; c <= '9'; ++c) add(c);
  for (int c = 1; c < 256; ++c) add(c);
  return order;
}

}  // namespace

std::optional<std::uint8_t> RobotRegistry::Find(const std::string& name) const {
  const auto it = ids_.find(name);
  if (it == ids_.end()) return std::nullopt;
  return it->second;
}

std::optional<std::uint8_t> RobotRegistry::FindOrAdd(const std::string& name) {
  if (const auto id = Find(name)) return id;
  static const std::array<std::uint8_t, kMaxRobots> kOrder = MakeIdOrder();
  if (size() >= kMaxRobots) return std::nullopt;
  const std::uint8_t id = kOrder[size()];
  ids_.emplace(name, id);
  order_.push_back(id);
  names_[id] = name;
  return id;
}

}  // namespace slamd::server
