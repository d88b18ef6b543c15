// Estimator::ApplyPoseWindow and Estimator::RemoveVariables: the lifelong window
// (EstimatorParams::window) by node removal.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

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
  NodeRemovalRecord done;
  // A Chow-Liu tree's root: a keyframe, which the window keeps, not a pose a later chunk or
  // pass removes (that removal would take in the whole tree).
  (void)RemoveVariables(removed, plan.keyframes, &done);
  return done;
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
  PoseWindowPlan plan;
  for (auto& [robot, indices] : behind) {
    const double d = params_.WindowOf(registry_.Name(robot)).keyframe_spacing_m;
    std::sort(indices.begin(), indices.end());
    std::map<std::array<long, 3>, std::vector<core::Vector3>> grid;
    const auto near_kept = [&](const core::Vector3& at, const std::array<long, 3>& cell) {
      for (long dx = -1; dx <= 1; ++dx) {
        for (long dy = -1; dy <= 1; ++dy) {
          for (long dz = -1; dz <= 1; ++dz) {
            const auto it = grid.find({cell[0] + dx, cell[1] + dy, cell[2] + dz});
            if (it == grid.end()) continue;
            for (const core::Vector3& k : it->second) {
              if ((k - at).norm() < d) return true;
            }
          }
        }
      }
      return false;
    };
    for (std::uint64_t index : indices) {
      const core::Key key = core::MakeKey('x', index, robot);
      const std::optional<core::Vector3> at = PositionOf(isam_->CalculateEstimate(key));
      bool keep = false;
      if (d > 0.0 && at) {
        const std::array<long, 3> cell = {std::lround(std::floor((*at)[0] / d)),
                                          std::lround(std::floor((*at)[1] / d)),
                                          std::lround(std::floor((*at)[2] / d))};
        keep = !near_kept(*at, cell);
        if (keep) grid[cell].push_back(*at);
      }
      (keep ? plan.keyframes : plan.removed).push_back(key);
    }
  }
  std::sort(plan.keyframes.begin(), plan.keyframes.end());
  return plan;
}

core::Status Estimator::RemoveVariables(std::span<const core::Key> keys,
                                        const std::vector<core::Key>& roots,
                                        NodeRemovalRecord* done, const core::Values* at) {
  NodeRemovalRecord local;
  if (!done) done = &local;
  *done = {};
  FinishUpdate();
  if (Rebuilding()) {
    return core::FailedPrecondition("node removal while a rebuild is in flight");
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
    status = RemoveChunk(keys.subspan(first, end - first), roots, at, done);
  }
  if (done->keys.empty()) return status;
  counters_.removed_variables += static_cast<std::int64_t>(done->keys.size());
  marginals_ = std::make_unique<core::Isam2Marginals>(
      isam_.get(), core::MarginalsParams{.threads = marginals_threads_});
  chi2_sequence_ = -1;  // the chi2 changed with the factors
  PublishSnapshot(false);
  return status;
}

core::Status Estimator::RemoveChunk(std::span<const core::Key> keys,
                                    const std::vector<core::Key>& roots, const core::Values* at,
                                    NodeRemovalRecord* done) {
  std::vector<core::Key> used;
  const auto keyframe = [&](core::Key key) {
    const bool preferred = std::binary_search(roots.begin(), roots.end(), key);
    if (preferred) used.push_back(key);
    return preferred;
  };
  const core::Isam2RemovalResult r = isam_->RemoveVariables(
      keys,
      {.form = params_.window.sparse_summaries ? core::NodeRemovalParams::Form::kChowLiu
                                               : core::NodeRemovalParams::Form::kDense,
       .prefer_root = keyframe,
       .edge_frame = core::TreeEdgeFrame::kParent,
       .tree_parents = params_.window.summary_parents},
      at);
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
  // Aliases anchored at a removed pose go with it.
  const std::set<core::Key> gone(keys.begin(), keys.end());
  std::erase_if(reduced_.aliases, [&](const auto& a) { return gone.count(a.second.anchor) != 0; });
  num_factors_ -= static_cast<std::int64_t>(r.removed_factors.size());
  residual_dimension_ -= r.removed_dimension;
  for (int f : r.summary_factors) {
    ++num_factors_;
    residual_dimension_ += isam_->factor_slots()[f]->dim();
  }
  return core::Status::Ok();
}

}  // namespace slamd::server
