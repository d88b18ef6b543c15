// RobotRegistry: robot name -> the 8-bit robot id in core::Key (core/base/key.h), assigned in
// order of first appearance: 'a'..'z', 'A'..'Z', '0'..'9' first (so KeyToString stays
// readable), then the remaining ids 1..255. Id 0 is never used (it means "no robot" in Key).
// At most 255 robots. Not thread-safe (owned by the estimator thread).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace slamd::server {

class RobotRegistry {
 public:
  static constexpr int kMaxRobots = 255;

  // The id of `name`, or nullopt when it has none yet.
  std::optional<std::uint8_t> Find(const std::string& name) const;
  // The id of `name`, assigning the next free one on first sight; nullopt when all are taken.
  std::optional<std::uint8_t> FindOrAdd(const std::string& name);
  // The name of a registered id ("" when unknown).
  const std::string& Name(std::uint8_t id) const { return names_[id]; }
  int size() const { return static_cast<int>(ids_.size()); }
  // Registered ids in assignment order.
  const std::vector<std::uint8_t>& ids() const { return order_; }

 private:
  std::unordered_map<std::string, std::uint8_t> ids_;
  std::vector<std::uint8_t> order_;
  std::string names_[256];
};

}  // namespace slamd::server
