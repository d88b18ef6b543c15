// The estimator's reduced pose graph (server/estimator/reduced_graph.h): which new poses become
// aliases, how measurements on aliases are composed onto nodes, and the aliases' lifetime.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "core/factors/between_factor.h"
#include "core/factors/factor_registry.h"
#include "core/factors/relative_point_factor.h"
#include "server/estimator/estimator.h"

namespace slamd::server {
namespace {

using core::Key;
using core::Variable;

// Nodes are looked up in a grid rebuilt from their current estimates this often (updates): a
// map corrected by more than a cell since is searched with stale cells until then.
constexpr std::int64_t kGridRefreshUpdates = 200;

// The factor of a composed measurement between `a` and `b`: a between factor for a relative
// pose, a relative point for a point in a's frame; null when the covariance is unusable.
core::FactorPtr ComposedFactor(Key a, Key b, const ComposedMeasurement& m,
                               const core::RobustKernel& robust) {
  core::Result<core::NoiseModel> noise = core::NoiseModel::FromCovariance(m.covariance);
  if (!noise.ok()) return nullptr;
  return std::visit(
      [&](const auto& z) -> core::FactorPtr {
        using T = std::decay_t<decltype(z)>;
        if constexpr (std::is_same_v<T, core::Pose2> || std::is_same_v<T, core::Pose3>) {
          return std::make_shared<core::BetweenFactor<T>>(a, b, z, std::move(noise).value(),
                                                          robust);
        } else if constexpr (std::is_same_v<T, core::Point2>) {
          return std::make_shared<core::RelativePointFactor<core::Pose2, core::Point2>>(
              a, b, z, std::move(noise).value(), robust);
        } else if constexpr (std::is_same_v<T, core::Point3>) {
          return std::make_shared<core::RelativePointFactor<core::Pose3, core::Point3>>(
              a, b, z, std::move(noise).value(), robust);
        } else {
          SLAMD_CHECK(false) << "reduced pose graph: no composed factor for this measurement";
          return nullptr;
        }
      },
      m.measured);
}

// Whether two estimates of one pose agree: their difference within the 99.9 % quantile of χ²
// under the sum of their covariances (anchors' own uncertainty left out). A loop closure that
// disagrees with the odometry composed since the anchor (a wrong match) does not re-anchor.
bool Consistent(const Variable& x, const Eigen::MatrixXd& cov_x, const Variable& y,
                const Eigen::MatrixXd& cov_y) {
  const Eigen::VectorXd d = core::LocalCoordinates(x, y);
  const double m = d.dot((cov_x + cov_y).ldlt().solve(d));
  return m < (d.size() == 3 ? 16.27 : 22.46);  // χ²(3), χ²(6) at 0.999
}

}  // namespace

const EstimatorParams::ReducedGraph* Estimator::ReducedFor(std::uint8_t robot) const {
  const EstimatorParams::ReducedGraph& r = params_.ReducedOf(registry_.Name(robot));
  return r.distance_m > 0.0 ? &r : nullptr;
}

const PoseAlias* Estimator::FindAlias(Key pose, const Staged& s) const {
  if (const auto staged = s.reduced.aliases.find(pose); staged != s.reduced.aliases.end()) {
    return staged->second ? &*staged->second : nullptr;
  }
  const auto it = reduced_.aliases.find(pose);
  return it == reduced_.aliases.end() ? nullptr : &it->second;
}

Variable Estimator::AliasEstimate(const PoseAlias& alias, const Staged* s) const {
  const Variable anchor = s != nullptr && s->values.Contains(alias.anchor)
                              ? s->values.Get(alias.anchor)
                              : isam_->CalculateEstimate(alias.anchor);
  return ComposePoses(anchor, alias.offset);
}

Outcome Estimator::AddReduced(core::FactorPtr factor, Key first, const MeasurementId& id, Staged* s,
                              Verdict* v) {
  const std::span<const core::Key> keys = factor->keys();
  const std::optional<Variable> relative = core::MeasuredRelativePose(*factor);
  ComposedMeasurement z;
  if (relative) z = {*relative, factor->noise_model().Covariance()};
  const auto resolve = [&](Key k) {
    const PoseAlias* alias = FindAlias(k, *s);
    return alias != nullptr ? *alias : NodeAlias(k, Estimate(k, *s));
  };
  const auto fail = [&](const std::string& why) {
    *v = {RejectReason::kBadMeasurement, why};
    return Outcome::kRejected;
  };
  const auto add_as_is = [&] {
    s->ids.emplace_back(s->factors.size(), id, first);
    s->factors.Add(factor);
    return Outcome::kApplied;
  };

  if (s->reduced.pending_pose) {
    const auto [pending, value] = *std::exchange(s->reduced.pending_pose, std::nullopt);
    const int at = keys[0] == pending ? 0 : (keys.size() == 2 && keys[1] == pending ? 1 : -1);
    if (relative && at >= 0 && factor->robust_kernel().is_none()) {
      const Key other = keys[1 - at];
      const PoseAlias alias = ComposeAlias(resolve(other), at == 1 ? z : InverseRelative(z));
      if (NearNode(value, *ReducedFor(core::KeyRobot(pending)), *s)) {
        s->reduced.aliases[pending] = alias;
        s->reduced.merged.emplace_back(id, std::move(factor));
        return Outcome::kApplied;
      }
      if (FindAlias(other, *s) == nullptr) {
        (void)s->values.Insert(pending, value);
        return add_as_is();
      }
      // From its robot's last node by the odometry composed since (staged before the pose, so
      // that a refusal leaves no unconstrained variable in the batch).
      if (!AddComposed(alias.anchor, pending, 0, {alias.offset, alias.covariance}, {}, s)) {
        return fail("the composed odometry's covariance is not positive definite");
      }
      (void)s->values.Insert(pending, value);
      s->reduced.merged.emplace_back(id, std::move(factor));
      return Outcome::kApplied;
    }
    (void)s->values.Insert(pending, value);  // placed by another kind of factor: a node
  }

  std::vector<Key> aliased;
  for (Key k : keys) {
    if (FindAlias(k, *s) != nullptr) aliased.push_back(k);
  }
  if (aliased.empty()) return add_as_is();
  if (relative) {  // odometry or a loop closure between known poses
    const PoseAlias a = resolve(keys[0]);
    const PoseAlias b = resolve(keys[1]);
    if (a.anchor != b.anchor &&
        !AddComposed(a.anchor, b.anchor, 0, ComposeBetween(a, z, b), factor->robust_kernel(), s)) {
      return fail("the composed relative pose's covariance is not positive definite");
    }
    // A closure from a robot's newest pose re-anchors it when that makes it more certain.
    for (int i = 0; i < 2 && factor->robust_kernel().is_none(); ++i) {
      const PoseAlias* current = FindAlias(keys[i], *s);
      if (current == nullptr ||
          robots_[core::KeyRobot(keys[i])].newest != core::KeyIndex(keys[i])) {
        continue;
      }
      PoseAlias through = ComposeAlias(i == 0 ? b : a, i == 0 ? InverseRelative(z) : z);
      if (through.covariance.trace() < current->covariance.trace() &&
          Consistent(AliasEstimate(*current, s), current->covariance, AliasEstimate(through, s),
                     through.covariance)) {
        s->reduced.aliases[keys[i]] = std::move(through);
      }
    }
    s->reduced.merged.emplace_back(id, std::move(factor));
    return Outcome::kApplied;
  }
  if (IsRelativePoint(*factor) && aliased.size() == 1 && aliased[0] == keys[0]) {
    const ComposedMeasurement point =
        ComposePoint(resolve(keys[0]), {*factor->Measured(), factor->noise_model().Covariance()});
    // A window's alias (no reduced graph policy) links as the reduced graph does by default.
    const EstimatorParams::ReducedGraph* policy = ReducedFor(core::KeyRobot(keys[0]));
    const bool link = policy == nullptr || policy->link_mapped_landmarks;
    if (!AddComposed(resolve(keys[0]).anchor, keys[1], 1, point, factor->robust_kernel(), s,
                     link)) {
      return fail("the composed point's covariance is not positive definite");
    }
    s->reduced.merged.emplace_back(id, std::move(factor));
    return Outcome::kApplied;
  }
  // Other factors need the pose as a node: the robot's newest pose becomes one; an older one
  // is past (its robot moved on from it).
  for (Key k : aliased) {
    if (robots_[core::KeyRobot(k)].newest != core::KeyIndex(k)) {
      *v = {RejectReason::kUnknownPose,
            core::KeyToString(k) + " is no node but an alias of " +
                core::KeyToString(FindAlias(k, *s)->anchor) +
                " (reduced pose graph or lifelong window, estimator.reduced / window); only "
                "odometry, loop closures and relative-point landmarks compose onto an older pose"};
      return Outcome::kRejected;
    }
  }
  for (Key k : aliased) {
    if (!Promote(k, s)) return fail("the composed odometry's covariance is not positive definite");
  }
  return add_as_is();
}

bool Estimator::Promote(Key pose, Staged* s) {
  const PoseAlias alias = *FindAlias(pose, *s);
  if (!AddComposed(alias.anchor, pose, 0, {alias.offset, alias.covariance}, {}, s)) return false;
  (void)s->values.Insert(pose, AliasEstimate(alias, s));
  s->reduced.aliases[pose] = std::nullopt;
  return true;
}

bool Estimator::AddComposed(Key a, Key b, int kind, const ComposedMeasurement& m,
                            const core::RobustKernel& robust, Staged* s, bool link) {
  // One composed measurement per pair and kind: later ones share the errors of their aliases'
  // offsets with it (and, after a re-anchoring, a closure already used), so fusing them as
  // independent made the map overconfident and biased (BENCHMARKS.md, "Lifelong"). A robust one
  // (a term that is not a Gaussian) is a kind of its own: the pair keeps its first of each.
  const MeasurementId id{'r', std::min(a, b), std::max(a, b), kind + (robust.is_none() ? 0 : 2)};
  const bool held = applied_.count(id) != 0 ||
                    std::any_of(s->ids.begin(), s->ids.end(),
                                [&](const auto& staged) { return std::get<1>(staged) == id; });
  const bool mapped = isam_->linearization_point().Contains(b) || s->values.Contains(b);
  if (held || (!link && mapped)) {
    ++s->reduced.left_out;
    return true;
  }
  core::FactorPtr f = ComposedFactor(a, b, m, robust);
  if (!f) return false;
  s->ids.emplace_back(s->factors.size(), id, a);
  s->factors.Add(std::move(f));
  return true;
}

bool Estimator::NearNode(const Variable& at, const EstimatorParams::ReducedGraph& policy,
                         const Staged& s) const {
  const std::optional<Eigen::Vector3d> position = PositionOf(at);
  if (!position) return false;
  const double max_angle = policy.angle_deg * M_PI / 180.0;
  const auto near = [&](const Variable& node) {
    if (node.index() != at.index()) return false;
    const PoseDistance d = DistanceBetween(node, at);
    return d.distance < policy.distance_m && d.angle < max_angle;
  };
  for (Key key : s.values.keys()) {  // nodes of this batch
    if (core::KeySymbol(key) == 'x' && near(s.values.Get(key))) return true;
  }
  if (reduced_.grid_sequence < 0 || sequence_ >= reduced_.grid_sequence + kGridRefreshUpdates) {
    double cell = params_.reduced.distance_m;
    for (const auto& r : params_.robot_reduced) cell = std::max(cell, r.reduced.distance_m);
    reduced_.grid.Reset(cell);
    reduced_.grid_sequence = sequence_;
    for (Key key : isam_->linearization_point().keys()) {
      if (core::KeySymbol(key) != 'x') continue;
      if (const auto p = PositionOf(isam_->CalculateEstimate(key))) reduced_.grid.Add(key, *p);
    }
  }
  return reduced_.grid.Any(*position, policy.distance_m, [&](Key key) {
    return isam_->linearization_point().Contains(key) && near(isam_->CalculateEstimate(key));
  });
}

void Estimator::CommitReduced(Staged* s) {
  counters_.reduced_left_out += s->reduced.left_out;
  for (auto& [key, alias] : s->reduced.aliases) {
    if (alias) {
      counters_.merged_poses += reduced_.aliases.count(key) == 0 ? 1 : 0;
      reduced_.aliases[key] = std::move(*alias);
    } else {
      reduced_.aliases.erase(key);
    }
  }
  // A merged measurement is forgotten with the alias it names (the first, when both are).
  for (auto& [id, factor] : s->reduced.merged) {
    const Key a = std::get<1>(id);
    reduced_.merged_by_pose[reduced_.aliases.count(a) != 0 ? a : std::get<2>(id)].push_back(id);
    reduced_.merged[id] = core::MeasurementDigest(*factor);
  }
  if (reduced_.grid_sequence >= 0) {
    for (Key key : s->values.keys()) {
      if (core::KeySymbol(key) != 'x') continue;
      if (const auto at = PositionOf(s->values.Get(key))) reduced_.grid.Add(key, *at);
    }
  }
  // Each robot keeps its newest keep_aliases aliases (and what was merged naming its poses).
  for (std::uint8_t robot : registry_.ids()) {
    const EstimatorParams::ReducedGraph* policy = ReducedFor(robot);
    if (policy == nullptr || !robots_[robot].anchored) continue;
    const std::uint64_t newest = robots_[robot].newest;
    const auto keep = static_cast<std::uint64_t>(policy->keep_aliases);
    if (newest > keep) ForgetAliases(robot, newest - keep);
  }
}

void Estimator::ForgetAliases(std::uint8_t robot, std::uint64_t before) {
  const Key begin = core::MakeKey('x', 0, robot);
  const Key end = core::MakeKey('x', before, robot);
  reduced_.aliases.erase(reduced_.aliases.lower_bound(begin), reduced_.aliases.lower_bound(end));
  const auto from = reduced_.merged_by_pose.lower_bound(begin);
  const auto to = reduced_.merged_by_pose.lower_bound(end);
  for (auto it = from; it != to; ++it) {
    for (const MeasurementId& id : it->second) reduced_.merged.erase(id);
  }
  reduced_.merged_by_pose.erase(from, to);
}

}  // namespace slamd::server
