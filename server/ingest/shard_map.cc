#include "server/ingest/shard_map.h"

#include "server/ingest/field_checks.h"

namespace slamd::server {
namespace {

// InvalidArgument with CheckName's message ("shards.shard.name: character 2 ...").
core::Status CheckShardName(const std::string& field, const std::string& name) {
  const Verdict v = internal::CheckName(field, name, 64);
  return v.ok() ? core::Status::Ok() : core::InvalidArgument(v.message);
}

}  // namespace

const std::string& ShardMap::OwnerOf(const std::string& robot) const {
  static const std::string kNone;
  if (shards.empty()) return kNone;
  for (const Shard& s : shards) {
    for (const std::string& r : s.robots) {
      if (r == robot) return s.name;
    }
  }
  return shards.front().name;
}

std::vector<std::string> ShardMap::Neighbours() const {
  std::vector<std::string> out;
  for (const Shard& s : shards) {
    if (s.name != self) out.push_back(s.name);
  }
  return out;
}

core::Status ShardMap::Validate() const {
  if (self.empty()) {
    if (!shards.empty()) return core::InvalidArgument("shards.self: empty, but shards are listed");
    return core::Status::Ok();
  }
  std::set<std::string> names, robots;
  bool found = false;
  for (const Shard& s : shards) {
    SLAMD_RETURN_IF_ERROR(CheckShardName("shards.shard.name", s.name));
    if (!names.insert(s.name).second) {
      return core::InvalidArgument("shards.shard.name = '" + s.name + "': listed twice");
    }
    found = found || s.name == self;
    for (const std::string& r : s.robots) {
      SLAMD_RETURN_IF_ERROR(CheckShardName("shards.shard.robots", r));
      if (!robots.insert(r).second) {
        return core::InvalidArgument("shards.shard.robots = '" + r + "': owned by two shards");
      }
    }
  }
  if (!found) {
    return core::InvalidArgument("shards.self = '" + self + "': not one of shards.shard");
  }
  return core::Status::Ok();
}

}  // namespace slamd::server
