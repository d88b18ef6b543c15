#include "server/query/query_service.h"

#include <algorithm>
#include <chrono>
#include <map>

#include "server/messages/frame_observations.h"

namespace slamd::server {
namespace {

class Deadline {
 public:
  explicit Deadline(double budget_s)
      : end_(std::chrono::steady_clock::now() +
             std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                 std::chrono::duration<double>(budget_s))) {}
  bool passed() const { return std::chrono::steady_clock::now() > end_; }

 private:
  std::chrono::steady_clock::time_point end_;
};

}  // namespace

QueryAnswer AnswerQuery(Estimator& estimator, const QueryRequest& query, double budget_s) {
  const Deadline deadline(budget_s);
  QueryAnswer answer;
  std::vector<core::Key> keys;
  std::string missing;
  for (const WireKey& wk : query.keys) {
    VariableAnswer& v = answer.results.emplace_back();
    v.key = wk;
    const std::optional<core::Key> key = estimator.KeyOf(wk);
    if (!key) {
      if (missing.empty()) missing = WireKeyName(wk);
      continue;
    }
    v.found = true;
    v.value = estimator.solver().CalculateEstimate(*key);
    keys.push_back(*key);
    if (!query.want_marginals) continue;
    if (deadline.passed()) {
      answer.partial = true;
      answer.error = "marginals not ready within the query budget";
      continue;
    }
    const core::Status s = estimator.Marginal(*key, &v.covariance);
    if (!s.ok()) {
      answer.partial = true;
      answer.error = "marginal of " + WireKeyName(wk) + ": " + s.message();
    }
  }
  if (query.want_joint_marginal) {
    if (!missing.empty()) {
      answer.partial = true;
      answer.error = "joint marginal: " + missing + " is not in the graph";
    } else if (!keys.empty()) {
      const core::Status s = estimator.JointMarginal(keys, &answer.joint);
      if (!s.ok()) {
        answer.partial = true;
        answer.error = "joint marginal: " + s.message();
        answer.joint.resize(0, 0);
      }
    }
  }
  return answer;
}

std::vector<RobotMap> CollectMaps(Estimator& estimator, const std::string& robot, bool marginals,
                                  double budget_s, bool* partial) {
  const Deadline deadline(budget_s);
  *partial = false;
  const RobotRegistry& registry = estimator.registry();
  std::map<std::uint8_t, size_t> slot;  // robot id -> position in maps
  std::vector<RobotMap> maps;
  for (std::uint8_t id : registry.ids()) {
    if (robot != "*" && registry.Name(id) != robot) continue;
    // Another shard's robot (its poses shared here by closures): its owner publishes it.
    if (!estimator.params().shards.Owns(registry.Name(id))) continue;
    slot[id] = maps.size();
    maps.push_back({.robot = registry.Name(id)});
  }
  // Every robot's map comes with the shared map's landmarks ('m' keys of robot id 0, which no
  // robot has) as a map of robot "".
  const bool shared = robot == "*";
  if (shared) {
    slot[0] = maps.size();
    maps.push_back({.robot = "", .is3d = true});
  }
  if (maps.empty()) return maps;
  if (marginals) estimator.ComputeAllMarginals();
  const core::Isam2& solver = estimator.solver();
  for (core::Key key : solver.linearization_point().keys()) {
    const auto it = slot.find(core::KeyRobot(key));
    if (it == slot.end() || (it->first == 0 && core::KeySymbol(key) != kMapLandmarkSymbol)) {
      continue;
    }
    RobotMap& map = maps[it->second];
    MapEntry entry{.index = core::KeyIndex(key), .value = solver.CalculateEstimate(key)};
    if (marginals) {
      if (deadline.passed()) {
        *partial = true;
      } else if (!estimator.CachedMarginal(key, &entry.covariance).ok()) {
        *partial = true;
      }
    }
    const bool is_pose = core::KeySymbol(key) == 'x';
    if (is_pose) map.is3d = std::holds_alternative<core::Pose3>(entry.value);
    (is_pose ? map.poses : map.landmarks).push_back(std::move(entry));
  }
  if (shared && maps.back().landmarks.empty()) maps.pop_back();
  for (RobotMap& map : maps) {
    const auto by_index = [](const MapEntry& a, const MapEntry& b) { return a.index < b.index; };
    std::sort(map.poses.begin(), map.poses.end(), by_index);
    std::sort(map.landmarks.begin(), map.landmarks.end(), by_index);
  }
  return maps;
}

}  // namespace slamd::server
