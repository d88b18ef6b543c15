// ShardMap: which map shard owns which robot (docs/SCALING.md). A sharded slamd takes the
// messages of the robots it owns (a loop closure by its robot_a), keeps the poses of other
// shards' robots that its closures name, and exchanges summaries on them with their owners.
// Unsharded (no shards listed), every robot is this slamd's.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/base/status.h"

namespace slamd::server {

struct ShardMap {
  std::string self;  // this slamd's shard; "" when not sharded
  struct Shard {
    std::string name;
    std::vector<std::string> robots;
  };
  // Every shard of the deployment (this one too) with the robots it owns; a robot no shard
  // lists is the first shard's.
  std::vector<Shard> shards;

  bool sharded() const { return !self.empty(); }
  // The shard that owns `robot` ("" when not sharded).
  const std::string& OwnerOf(const std::string& robot) const;
  bool Owns(const std::string& robot) const { return !sharded() || OwnerOf(robot) == self; }
  // The other shards' names.
  std::vector<std::string> Neighbours() const;

  // InvalidArgument naming the field: self not among the shards, a repeated shard name or
  // robot, a name that is not 1..64 chars of [A-Za-z0-9_.-], shards listed without self.
  core::Status Validate() const;
};

}  // namespace slamd::server
