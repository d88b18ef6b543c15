// The lifelong window's records (Estimator::ApplyPoseWindow, pose_window.cc): what a removal
// journals, and the walk that decides which old poses go.
#pragma once

#include <map>
#include <utility>
#include <vector>

#include "core/base/key.h"
#include "core/factors/values.h"
#include "server/snapshot/estimator_state.h"  // PoseAlias

namespace slamd::server {

// Variables node removal took out, and the values they and their Markov blanket were
// marginalised at: what the journal keeps, so that a replay makes the same summary wherever its
// own θ drifted (Isam2::RemoveVariables' `at`). And the keyframes the removals' blankets held,
// the roots their summary trees were given in preference (the window's choice, from estimates
// that a replay after a snapshot may not reproduce bit for bit), sorted. And the removed poses
// held as aliases of keyframes (EstimatorParams::PoseWindow::keep_aliases; from the estimate and
// the marginals before the removal, which a replay may not reproduce either), sorted by pose.
struct NodeRemovalRecord {
  std::vector<core::Key> keys;
  core::Values at;
  std::vector<core::Key> roots;
  std::vector<std::pair<core::Key, PoseAlias>> aliases;
};

// The window's walk over each robot's poses behind its window: the keyframes it keeps (sorted),
// the poses it removes (by robot, oldest first) and, for each of those, the nearest keyframe
// that made it redundant (its alias's anchor).
struct PoseWindowPlan {
  std::vector<core::Key> keyframes, removed;
  std::map<core::Key, core::Key> anchor_of;
};

}  // namespace slamd::server
