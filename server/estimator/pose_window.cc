// Estimator::ApplyPoseWindow and Estimator::RemoveVariables: the lifelong window
// (EstimatorParams::window) by node removal.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "core/base/timing.h"
#include "core/factors/factor_registry.h"
#include "server/estimator/estimator.h"

namespace slamd::server {
namespace {

// Node removal factors the removed variables' stacked Jacobian densely (node_removal.h): cost
// O(rows x columns²). Removed in chunks of this many, in order, each costs little, and a window
// pass removes at most kMaxRemovedPerPass or half of the poses behind the window, whichever is
// more (the rest at the next update's pass): a pass that finds a long stretch of old poses does
// not stall the estimator for seconds, and the window still keeps up with a sustained load
// whose updates each bring thousands of poses.
constexpr std::size_t kRemovalChunk = 16;
constexpr std::size_t kMaxRemovedPerPass = 256;
// A removed pose's alias costs a joint marginal (0.2 ms a pose in the lifelong soak at its
// normal rate, 1-10 ms under a sustained overload, when the tree's top is large): a pass spends
// at most this long on them, the robots' newest removed poses first, the rest removed without.
constexpr double kAliasBudgetS = 0.05;

}  // namespace

NodeRemovalRecord Estimator::ApplyPoseWindow() {
  const bool any = params_.window.keep_poses > 0 ||
                   std::any_of(params_.robot_windows.begin(), params_.robot_windows.end(),
                               [](const auto& r) { return r.window.keep_poses > 0; });
  if (!any || sequence_ == window_sequence_ ||
      (sequence_ < window_sequence_ + params_.window.every_updates && !window_unfinished_)) {
    return {};
  }
  FinishUpdate();
  if (Rebuilding()) return {};  // the rebuild copied the graph: after its swap
  window_sequence_ = sequence_;
  PoseWindowPlan plan = WindowPlan();
  std::vector<core::Key>& removed = plan.removed;
  // A robot's newest pose held as an alias (reduced pose graph) keeps its anchor.
  std::set<core::Key> anchors;
  for (std::uint8_t robot : registry_.ids()) {
    const auto it = reduced_.aliases.find(core::MakeKey('x', robots_[robot].newest, robot));
    if (it != reduced_.aliases.end()) anchors.insert(it->second.anchor);
  }
  std::erase_if(removed, [&](core::Key k) { return anchors.count(k) != 0; });
  const std::size_t most = std::max(kMaxRemovedPerPass, removed.size() / 2);
  window_unfinished_ = removed.size() > most;
  if (removed.empty()) return {};
  if (window_unfinished_) removed.resize(most);
  // A chunk that fails (nothing of it changed) ends the pass; the next tries again.
  // A Chow-Liu tree's root: a keyframe, which the window keeps, not a pose a later chunk or
  // pass removes (that removal would take in the whole tree).
  NodeRemovalRecord what{.keys = removed, .roots = std::move(plan.keyframes)};
  what.aliases = WindowAliases(plan);
  NodeRemovalRecord done;
  (void)RemoveVariables(what, &done);
  return done;
}

std::vector<std::pair<core::Key, PoseAlias>> Estimator::WindowAliases(const PoseWindowPlan& plan) {
  // The candidates by robot, newest first: those within keep_aliases that a keyframe replaced.
  std::map<std::uint8_t, std::vector<core::Key>> candidates;
  for (auto it = plan.removed.rbegin(); it != plan.removed.rend(); ++it) {
    const std::uint8_t robot = core::KeyRobot(*it);
    const EstimatorParams::PoseWindow& w = params_.WindowOf(registry_.Name(robot));
    if (plan.anchor_of.count(*it) != 0 &&
        core::KeyIndex(*it) + static_cast<std::uint64_t>(w.keep_poses + w.keep_aliases) >=
            robots_[robot].newest) {
      candidates[robot].push_back(*it);
    }
  }
  // The robots in turn, until the budget is spent.
  std::vector<std::pair<core::Key, PoseAlias>> aliases;
  Eigen::MatrixXd joint;
  const core::Stopwatch timer;
  for (std::size_t round = 0, left = 1; left > 0 && timer.Seconds() < kAliasBudgetS; ++round) {
    left = 0;
    for (const auto& [robot, poses] : candidates) {
      if (round >= poses.size() || timer.Seconds() >= kAliasBudgetS) continue;
      left += poses.size() - round - 1;
      const core::Key pose = poses[round], anchor = plan.anchor_of.at(pose);
      const core::Key keys[] = {anchor, pose};
      if (marginals_->JointMarginal(keys, core::Isam2Marginals::Frame::kEstimate, &joint).ok()) {
        aliases.emplace_back(pose, RelativeAlias(anchor, isam_->CalculateEstimate(anchor),
                                                 isam_->CalculateEstimate(pose), joint));
      }
    }
  }
  std::sort(aliases.begin(), aliases.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  return aliases;
}

bool Estimator::WindowBehind() const {
  // Per robot with a window of k poses: how many of its poses in [newest - 2k, newest - k).
  std::map<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>> band;  // robot: k, poses
  for (std::uint8_t robot : registry_.ids()) {
    const int keep = params_.WindowOf(registry_.Name(robot)).keep_poses;
    if (keep > 0 && robots_[robot].anchored) band[robot] = {keep, 0};
  }
  if (band.empty()) return false;
  for (core::Key key : isam_->linearization_point().keys()) {
    if (core::KeySymbol(key) != 'x') continue;
    const auto it = band.find(core::KeyRobot(key));
    if (it == band.end()) continue;
    const std::uint64_t index = core::KeyIndex(key), keep = it->second.first;
    const std::uint64_t newest = robots_[it->first].newest;
    if (index + keep < newest && index + 2 * keep >= newest) ++it->second.second;
  }
  return std::any_of(band.begin(), band.end(),
                     [](const auto& b) { return 2 * b.second.second > b.second.first; });
}

PoseWindowPlan Estimator::WindowPlan() const {
  // Each robot's poses behind its window, by index.
  std::map<std::uint8_t, std::vector<std::uint64_t>> behind;
  for (core::Key key : isam_->linearization_point().keys()) {
    if (core::KeySymbol(key) != 'x') continue;
    const std::uint8_t robot = core::KeyRobot(key);
    const RobotState& r = robots_[robot];
    const std::uint64_t index = core::KeyIndex(key);
    const int keep = params_.WindowOf(registry_.Name(robot)).keep_poses;
    if (keep > 0 && r.anchored && index + static_cast<std::uint64_t>(keep) < r.newest) {
      behind[robot].push_back(index);
    }
  }
  // Keyframes are kept by place, not by time: walking a robot's old poses oldest first, a pose
  // is kept when no pose kept before it lies within keyframe_spacing_m (a grid of cells that
  // size finds the neighbours), so driving through a mapped area again adds no keyframe and
  // the graph of a robot that stays in a bounded area stays bounded.
  // A removed pose's nearest keyframe within keyframe_spacing_m is its alias's anchor.
  PoseWindowPlan plan;
  for (auto& [robot, indices] : behind) {
    const double d = params_.WindowOf(registry_.Name(robot)).keyframe_spacing_m;
    std::sort(indices.begin(), indices.end());
    std::map<std::array<long, 3>, std::vector<std::pair<core::Key, core::Vector3>>> grid;
    const auto nearest_kept = [&](const core::Vector3& at, const std::array<long, 3>& cell) {
      std::optional<core::Key> nearest;
      double best = d;
      for (long dx = -1; dx <= 1; ++dx) {
        for (long dy = -1; dy <= 1; ++dy) {
          for (long dz = -1; dz <= 1; ++dz) {
            const auto it = grid.find({cell[0] + dx, cell[1] + dy, cell[2] + dz});
            if (it == grid.end()) continue;
            for (const auto& [key, k] : it->second) {
              if ((k - at).norm() < best) {
                best = (k - at).norm();
                nearest = key;
              }
            }
          }
        }
      }
      return nearest;
    };
    for (std::uint64_t index : indices) {
      const core::Key key = core::MakeKey('x', index, robot);
      const std::optional<core::Vector3> at = PositionOf(isam_->CalculateEstimate(key));
      bool keep = false;
      if (d > 0.0 && at) {
        const std::array<long, 3> cell = {std::lround(std::floor((*at)[0] / d)),
                                          std::lround(std::floor((*at)[1] / d)),
                                          std::lround(std::floor((*at)[2] / d))};
        const std::optional<core::Key> nearest = nearest_kept(*at, cell);
        keep = !nearest;
        if (keep) grid[cell].emplace_back(key, *at);
        if (nearest) plan.anchor_of[key] = *nearest;
      }
      (keep ? plan.keyframes : plan.removed).push_back(key);
    }
  }
  std::sort(plan.keyframes.begin(), plan.keyframes.end());
  return plan;
}

core::Status Estimator::RemoveVariables(const NodeRemovalRecord& what, NodeRemovalRecord* done) {
  const std::span<const core::Key> keys = what.keys;
  NodeRemovalRecord local;
  if (!done) done = &local;
  *done = {};
  FinishUpdate();
  if (Rebuilding()) {
    return core::FailedPrecondition("node removal while a rebuild is in flight");
  }
  // An alias is of a pose removed here, anchored at a pose of its kind that stays; by pose.
  if (!std::is_sorted(what.aliases.begin(), what.aliases.end(),
                      [](const auto& a, const auto& b) { return a.first < b.first; })) {
    return core::InvalidArgument("node removal: the aliases are not sorted by pose");
  }
  const core::Values& theta = isam_->linearization_point();
  std::vector<core::Key> sorted(keys.begin(), keys.end());
  std::sort(sorted.begin(), sorted.end());
  const auto removed = [&](core::Key k) {
    return std::binary_search(sorted.begin(), sorted.end(), k);
  };
  for (const auto& [pose, alias] : what.aliases) {
    if (!removed(pose) || removed(alias.anchor) || !PositionOf(alias.offset) ||
        !theta.Contains(pose) || !theta.Contains(alias.anchor) ||
        core::TypeOf(theta.Get(alias.anchor)) != core::TypeOf(alias.offset) ||
        core::TypeOf(theta.Get(pose)) != core::TypeOf(alias.offset) ||
        alias.covariance.rows() != core::TangentDim(core::TypeOf(alias.offset)) ||
        alias.covariance.cols() != alias.covariance.rows()) {
      return core::InvalidArgument(
          "node removal: the alias of " + core::KeyToString(pose) + " (anchor " +
          core::KeyToString(alias.anchor) +
          ") is not of a removed pose anchored at a pose of its kind that stays, with an offset "
          "covariance of its dimension");
    }
  }
  // A chunk holds one robot's poses: the summary of several robots' would be one tree over
  // blankets that share nothing, its root in one robot's map and bridges of no information to
  // the others', which tie their maps together across the world (fill-in of the Bayes tree).
  core::Status status;
  for (std::size_t first = 0, end; first < keys.size() && status.ok(); first = end) {
    end = first + 1;
    while (end < keys.size() && end - first < kRemovalChunk &&
           core::KeyRobot(keys[end]) == core::KeyRobot(keys[first])) {
      ++end;
    }
    status = RemoveChunk(keys.subspan(first, end - first), what, done);
  }
  if (done->keys.empty()) return status;
  std::sort(done->aliases.begin(), done->aliases.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::uint8_t robot : registry_.ids()) {
    const EstimatorParams::PoseWindow& w = params_.WindowOf(registry_.Name(robot));
    const auto behind = static_cast<std::uint64_t>(w.keep_poses + w.keep_aliases);
    if (w.keep_poses > 0 && robots_[robot].newest > behind) {
      ForgetAliases(robot, robots_[robot].newest - behind);
    }
  }
  counters_.removed_variables += static_cast<std::int64_t>(done->keys.size());
  marginals_ = std::make_unique<core::Isam2Marginals>(
      isam_.get(), core::MarginalsParams{.threads = marginals_threads_});
  chi2_sequence_ = -1;  // the chi2 changed with the factors
  PublishSnapshot(false);
  return status;
}

core::Status Estimator::RemoveChunk(std::span<const core::Key> keys, const NodeRemovalRecord& what,
                                    NodeRemovalRecord* done) {
  std::vector<core::Key> used;
  const auto keyframe = [&](core::Key key) {
    const bool preferred = std::binary_search(what.roots.begin(), what.roots.end(), key);
    if (preferred) used.push_back(key);
    return preferred;
  };
  // The poses of the chunk held as aliases, and the digests of the measurements naming them that
  // an alias composes (the other kinds are rejected when sent again): kept with the alias
  // (ReducedGraphState::merged, forgotten with it), so that one sent again is held already, not
  // composed onto the keyframe as new information.
  std::map<core::Key, PoseAlias> held;
  for (core::Key key : keys) {
    const auto it = std::lower_bound(what.aliases.begin(), what.aliases.end(), key,
                                     [](const auto& a, core::Key k) { return a.first < k; });
    if (it != what.aliases.end() && it->first == key) held.insert(*it);
  }
  std::vector<std::tuple<core::Key, MeasurementId, std::uint64_t>> known;
  for (int n = 0; n < static_cast<int>(numbers_.size()) && !held.empty(); ++n) {
    const FactorNumbers::Entry& e = numbers_.entry(n);
    if (numbers_.slot(n) < 0 || e.dim == 0 || std::get<0>(e.id) == 'r') continue;  // 'r': composed
    const core::Factor& f = *isam_->factor_slots()[numbers_.slot(n)];
    for (core::Key on : {std::get<1>(e.id), std::get<2>(e.id)}) {
      if (held.count(on) == 0 || !Composable(f)) continue;
      known.emplace_back(on, e.id, core::MeasurementDigest(f));
      break;
    }
  }
  const core::Isam2RemovalResult r = isam_->RemoveVariables(
      keys,
      {.form = params_.window.sparse_summaries ? core::NodeRemovalParams::Form::kChowLiu
                                               : core::NodeRemovalParams::Form::kDense,
       .prefer_root = keyframe,
       .edge_frame = core::TreeEdgeFrame::kParent,
       .tree_parents = params_.window.summary_parents},
      what.at.empty() ? nullptr : &what.at);
  if (!r.status.ok()) return r.status;
  done->keys.insert(done->keys.end(), keys.begin(), keys.end());
  for (core::Key key : used) {
    const auto at_key = std::lower_bound(done->roots.begin(), done->roots.end(), key);
    if (at_key == done->roots.end() || *at_key != key) done->roots.insert(at_key, key);
  }
  for (core::Key key : r.marginalized_at.keys()) {
    (void)done->at.Insert(key, r.marginalized_at.Get(key));  // a later chunk's may repeat one
  }
  // The measurements of the removed factors are forgotten: their variables are gone, so the same
  // measurement sent again cannot be told apart from a new one by the graph.
  std::vector<int> number_of(isam_->factor_slots().size(), -1);
  for (int n = 0; n < static_cast<int>(numbers_.size()); ++n) {
    if (numbers_.slot(n) >= 0) number_of[numbers_.slot(n)] = n;
  }
  for (int f : r.removed_factors) {
    const int n = number_of[f];
    if (n < 0) continue;
    const auto it = applied_.find(numbers_.entry(n).id);
    if (it != applied_.end() && it->second == n) applied_.erase(it);
    numbers_.Release(n);
  }
  // A removed pose with an alias is held as it; aliases anchored at a removed pose follow its
  // alias (composed onto it), or go with it.
  const std::set<core::Key> gone(keys.begin(), keys.end());
  for (auto it = reduced_.aliases.begin(); it != reduced_.aliases.end();) {
    PoseAlias& alias = it->second;
    const auto via = gone.count(alias.anchor) != 0 ? held.find(alias.anchor) : held.end();
    if (via != held.end()) alias = ComposeAlias(via->second, {alias.offset, alias.covariance});
    it = gone.count(alias.anchor) != 0 ? reduced_.aliases.erase(it) : std::next(it);
  }
  for (auto& [key, alias] : held) {
    done->aliases.emplace_back(key, alias);
    reduced_.aliases[key] = std::move(alias);
  }
  for (const auto& [on, id, digest] : known) {
    reduced_.merged_by_pose[on].push_back(id);
    reduced_.merged[id] = digest;
  }
  num_factors_ -= static_cast<std::int64_t>(r.removed_factors.size());
  residual_dimension_ -= r.removed_dimension;
  for (int f : r.summary_factors) {
    ++num_factors_;
    residual_dimension_ += isam_->factor_slots()[f]->dim();
  }
  return core::Status::Ok();
}

}  // namespace slamd::server
