#include "server/estimator/estimator_params.h"

#include <string>

#include "core/factors/robust_kernel.h"

namespace slamd::server {

const EstimatorParams::PoseWindow& EstimatorParams::WindowOf(const std::string& robot) const {
  for (const RobotWindow& r : robot_windows) {
    if (r.robot == robot) return r.window;
  }
  return window;
}

const EstimatorParams::ReducedGraph& EstimatorParams::ReducedOf(const std::string& robot) const {
  for (const RobotReduced& r : robot_reduced) {
    if (r.robot == robot) return r.reduced;
  }
  return reduced;
}

core::Status EstimatorParams::Validate() const {
  const EstimatorParams& estimator = *this;
  if (new_robot_anchor != AnchorPolicy::kHoldUntilConnected &&
      new_robot_anchor != AnchorPolicy::kAnchorAtOrigin) {
    return core::InvalidArgument(
        "estimator.new_robot_anchor = " + std::to_string(static_cast<int>(new_robot_anchor)) +
        "; not a known policy");
  }
  SLAMD_CONFIG_CHECK(estimator.anchor_sigma, >, 0.0);
  SLAMD_CONFIG_CHECK(estimator.anchor_sigma, <=, 1e3);
  SLAMD_CONFIG_CHECK(estimator.max_held_messages, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.max_hold_updates, >=, 1);
  SLAMD_CONFIG_CHECK(estimator.chi2_interval_s, >=, 0.0);
  SLAMD_CONFIG_CHECK(estimator.background_relinearization_above, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.rebuild_catch_up_rounds, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.rebuild_catch_up_rounds, <=, 64);
  SLAMD_CONFIG_CHECK(estimator.landmark_min_views, >=, 2);
  SLAMD_CONFIG_CHECK(estimator.landmark_min_parallax_deg, >=, 0.0);
  SLAMD_CONFIG_CHECK(estimator.landmark_min_parallax_deg, <, 180.0);
  SLAMD_CONFIG_CHECK(estimator.landmark_min_disparity_px, >, 0.0);
  SLAMD_CONFIG_CHECK(estimator.landmark_max_reprojection_px, >, 0.0);
  SLAMD_CONFIG_CHECK(estimator.landmark_max_wait_updates, >=, 1);
  SLAMD_CONFIG_CHECK(estimator.max_track_observations, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.max_landmark_error_px, >, 0.0);
  SLAMD_CONFIG_CHECK(estimator.window.keep_poses, >=, 0);
  SLAMD_CONFIG_CHECK(estimator.window.keyframe_spacing_m, >=, 0.0);
  SLAMD_CONFIG_CHECK(estimator.window.every_updates, >=, 1);
  SLAMD_CONFIG_CHECK(estimator.window.summary_parents, >=, 1);
  SLAMD_CONFIG_CHECK(estimator.window.summary_parents, <=, 2);
  SLAMD_CONFIG_CHECK(estimator.window.keep_aliases, >=, 0);
  for (std::size_t i = 0; i < robot_windows.size(); ++i) {
    const std::string at = "estimator.robot_window[" + std::to_string(i) + "]";
    const PoseWindow& w = robot_windows[i].window;
    if (robot_windows[i].robot.empty()) return core::InvalidArgument(at + ".robot is empty");
    for (std::size_t j = 0; j < i; ++j) {
      if (robot_windows[j].robot == robot_windows[i].robot) {
        return core::InvalidArgument(at + ".robot = \"" + robot_windows[i].robot +
                                     "\"; already given a window");
      }
    }
    if (w.keep_poses < 0) {
      return core::InvalidArgument(at + ".keep_poses = " + std::to_string(w.keep_poses) +
                                   "; violates >= 0");
    }
    if (!(w.keyframe_spacing_m >= 0.0)) {
      return core::InvalidArgument(
          at + ".keyframe_spacing_m = " + std::to_string(w.keyframe_spacing_m) + "; violates >= 0");
    }
  }
  for (std::size_t i = 0; i <= robot_reduced.size(); ++i) {
    const std::string at = i == robot_reduced.size()
                               ? std::string("estimator.reduced")
                               : "estimator.robot_reduced[" + std::to_string(i) + "]";
    const ReducedGraph& r = i == robot_reduced.size() ? reduced : robot_reduced[i].reduced;
    if (i < robot_reduced.size()) {
      if (robot_reduced[i].robot.empty()) return core::InvalidArgument(at + ".robot is empty");
      for (std::size_t j = 0; j < i; ++j) {
        if (robot_reduced[j].robot == robot_reduced[i].robot) {
          return core::InvalidArgument(at + ".robot = \"" + robot_reduced[i].robot +
                                       "\"; already given a reduced graph");
        }
      }
    }
    if (!(r.distance_m >= 0.0 && r.distance_m < 1e6)) {
      return core::InvalidArgument(at + ".distance_m = " + std::to_string(r.distance_m) +
                                   "; violates >= 0 and < 1e6");
    }
    if (!(r.angle_deg > 0.0 && r.angle_deg <= 180.0)) {
      return core::InvalidArgument(at + ".angle_deg = " + std::to_string(r.angle_deg) +
                                   "; violates > 0 and <= 180");
    }
    if (r.keep_aliases < 1) {
      return core::InvalidArgument(at + ".keep_aliases = " + std::to_string(r.keep_aliases) +
                                   "; violates >= 1");
    }
  }
  const core::Result<core::RobustKernel::Kind> kind =
      core::RobustKernel::ParseKind(loop_closure_kernel);
  if (!kind.ok()) {
    return core::InvalidArgument("estimator.loop_closure_kernel = \"" + loop_closure_kernel +
                                 "\"; not one of none huber cauchy gemanmcclure dcs");
  }
  if (kind.value() != core::RobustKernel::Kind::kNone &&
      !core::RobustKernel::Create(kind.value(), loop_closure_kernel_parameter).ok()) {
    return core::InvalidArgument("estimator.loop_closure_kernel_parameter = " +
                                 std::to_string(loop_closure_kernel_parameter) +
                                 "; must be positive and finite");
  }
  SLAMD_RETURN_IF_ERROR(shards.Validate());
  return core::Status::Ok();
}

}  // namespace slamd::server
