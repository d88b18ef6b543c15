// The lifelong window's records (Estimator::ApplyPoseWindow, pose_window.cc): what a removal
// journals, and the walk that decides which old poses go.
#pragma once

#include <vector>

#include "core/base/key.h"
#include "core/factors/values.h"

namespace slamd::server {

// Variables node removal took out, and the values they and their Markov blanket were
// marginalised at: what the journal keeps, so that a replay makes the same summary wherever its
// own θ drifted (Isam2::RemoveVariables' `at`). And the keyframes the removals' blankets held,
// the roots their summary trees were given in preference (the window's choice, from estimates
// that a replay after a snapshot may not reproduce bit for bit), sorted.
struct NodeRemovalRecord {
  std::vector<core::Key> keys;
  core::Values at;
  std::vector<core::Key> roots;
};

// The window's walk over each robot's poses behind its window: the keyframes it keeps (sorted)
// and the poses it removes (by robot, oldest first).
struct PoseWindowPlan {
  std::vector<core::Key> keyframes, removed;
};

}  // namespace slamd::server
