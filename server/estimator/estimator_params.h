// EstimatorParams: the estimator's stateful policies (config section `estimator`).
#pragma once

#include <string>
#include <vector>

#include "core/base/status.h"
#include "server/ingest/shard_map.h"

// Returns InvalidArgument naming a config path ("estimator.anchor_sigma = 0; violates > 0") when
// `path op bound` does not hold (core's SLAMD_PARAM_CHECK names "Struct::field"; the config
// speaks in plain paths). For the Validate() of config sections.
#define SLAMD_CONFIG_CHECK(path, op, bound)                                          \
  do {                                                                               \
    if (!(path op bound)) {                                                          \
      return core::InvalidArgument(std::string(#path " = ") + std::to_string(path) + \
                                   "; violates " #op " " #bound);                    \
    }                                                                                \
  } while (false)

namespace slamd::server {

// What happens to a robot whose first message is not an absolute pose prior.
enum class AnchorPolicy {
  // Its messages are held until a loop closure ties one of its poses to a known robot (or a
  // pose prior arrives); bounded by max_held_messages / max_hold_updates, then rejected.
  kHoldUntilConnected = 1,
  // Its first pose is placed at the origin (identity) with a prior of sigma anchor_sigma.
  kAnchorAtOrigin = 2,
};

struct EstimatorParams {
  AnchorPolicy new_robot_anchor = AnchorPolicy::kHoldUntilConnected;
  // Standard deviation of the origin anchor prior, every tangent component [m, rad]; (0, 1e3].
  double anchor_sigma = 1e-3;
  // Messages that may wait for a pose they need (odometry ahead of the next expected pose, a
  // robot not anchored yet); beyond it the oldest is rejected (REASON_OUT_OF_ORDER_TIMEOUT). >= 0.
  int max_held_messages = 1000;
  // Solver updates a held message may wait before it is rejected the same way; >= 1.
  int max_hold_updates = 100;
  // status_t's chi2 (a pass over every factor) is recomputed at most this often while updates
  // stream in, and always once the estimate settles [s]; 0 = after every update. >= 0.
  // When > 0, it also waits 50x as long as the last pass took (at most 2% of the estimator's
  // time: a pass grows with the map), and a background rebuild's helper computes one for its
  // solver, which the swap hands over.
  double chi2_interval_s = 1.0;
  // Robust kernel for loop closures that do not name one (loop_closure_t.robust_kernel ""):
  // "none", "huber", "cauchy", "gemanmcclure" or "dcs" (core/factors/robust_kernel.h), and its
  // parameter (> 0 unless "none"). Limits the pull of wrong loop closures.
  std::string loop_closure_kernel = "none";
  double loop_closure_kernel_parameter = 1.0;
  // When an update is due to relinearise more variables than this, it relinearises none
  // (core::Isam2UpdateOptions::defer_relinearization_above); the estimator instead rebuilds the
  // solver from the live factors at the current estimate on a helper thread, while the live
  // solver keeps taking messages, and swaps it in once it is ready and has taken what the live
  // one took meanwhile. Such relinearisations re-eliminate most of the tree (1-5 ms on
  // manhattan.g2o and victoriaPark.txt, against ~0.01 ms for an odometry step), and every
  // message queued behind them waited: at 1 kHz the ingest-to-publish p99 went from 5.4-6.3 to
  // 1.9-2.3 ms (manhattan) and 4.5-5.4 to 2.5-3.5 ms (victoriaPark) in
  // `SLAMD_BENCH_RATES=1000 SLAMD_BENCH_SYNC=NEVER scripts/bench-server`. 256: no clear
  // difference (more rebuilds, which compete for the 2 cores). 0 = never (every
  // relinearisation in the update, as `slamctl bench` runs the solver). >= 0.
  int background_relinearization_above = 512;
  // At most this many catch-up rounds on the rebuild's helper thread, on what the live solver
  // took while it built (see estimator.h); the swap takes the rest in one update on the
  // estimator thread. On a large map a rebuild takes a second, and that second's messages made
  // the swap a 100-140 ms update (`scripts/soak`, >60k variables); with rounds it is 1 ms on
  // average, 7 ms at most. The cost: ~40-50% more RSS on such maps (glibc keeps what the
  // helper's thread allocated and the estimator thread later freed; `scripts/soak` at ~250k
  // variables: 3718 MB with rounds, 2477 MB without). 0 = no rounds. 0..64.
  int rebuild_catch_up_rounds = 8;

  // Camera landmarks (frame_observations_t): a landmark enters the graph once its views
  // determine it (core/sfm/landmark_initialization.h): at least landmark_min_views views (>= 2)
  // with landmark_min_parallax_deg between two rays ([0, 180)), or one stereo view with at least
  // landmark_min_disparity_px (> 0); in front of every camera and with an RMS reprojection
  // error of at most landmark_max_reprojection_px (> 0).
  int landmark_min_views = 2;
  double landmark_min_parallax_deg = 1.0;
  // A stereo view's depth error is depth × (disparity error / disparity): at 1 px of pixel noise
  // and 10 px of disparity, ~14 %. With 1 px, far points of a simulated city (`slamctl sim
  // camera-city --stereo`, baseline 0.5 m, up to 80 m) entered 30 % off, the replay's chi2 was
  // 2.5e6 and the server never settled; with 10 px, 29,840 over 40,960 residuals, settled.
  double landmark_min_disparity_px = 10.0;
  double landmark_max_reprojection_px = 4.0;
  // Its observations wait at most landmark_max_wait_updates solver updates (>= 1), and at most
  // max_track_observations wait in all (>= 0; the oldest landmark is dropped first); a dropped
  // landmark is answered by a reject_t saying why it was not determined.
  int landmark_max_wait_updates = 300;
  int max_track_observations = 200000;
  // A feature of a landmark in the graph farther than this from the landmark's projection is
  // rejected as a wrong match [px]; > 0.
  double max_landmark_error_px = 50.0;

  // Lifelong window (server/estimator/pose_window.cc): every `every_updates` updates, each
  // robot's poses more than `keep_poses` behind its newest are removed from the graph by node
  // removal (core/inference/node_removal.h: their factors become one exact linear factor on
  // their neighbours), except keyframes: an old pose is kept when no older kept pose of its
  // robot lies within `keyframe_spacing_m` (by place: revisiting a mapped area adds none, so a
  // robot in a bounded area keeps a bounded graph). Landmarks stay. Each removal is journaled.
  // keep_poses 0 = off (keep everything); >= 0; keyframe_spacing_m >= 0 (0: no keyframes, a
  // fixed-lag window); every_updates >= 1 (a pass that left poses behind, having removed as
  // many as one pass may, runs again at the next update: under load, updates take many poses
  // at once and the graph would otherwise grow between passes).
  // sparse_summaries (window's only, for every robot): each removal's summary is the Chow-Liu
  // tree of the exact one, its edges each in the parent's frame (core/inference/chow_liu.h:
  // TreeEdgeFrame::kParent), which also takes in the summaries already on its variables, so
  // that factors and the Bayes tree's fill-in stay bounded with the graph;
  // false: the exact dense summaries, which in a landmark world absorb each other and grow with
  // the area mapped until removals stall (BENCHMARKS.md, lifelong soak).
  // summary_parents (window's only; 1 or 2): sparse summaries condition each variable on its
  // tree parent and, with 2, also on the one other variable that tells most about it beyond
  // that (NodeRemovalParams::tree_parents): closer to the exact summaries, for a little more
  // fill-in and update time (BENCHMARKS.md, lifelong soak).
  // keep_aliases (>= 0): a robot's removed poses up to this many behind its window are held as
  // aliases of the keyframe that replaced them (offset and covariance from the estimate and
  // joint marginal before the removal), so that a loop closure naming one is composed onto the
  // keyframe instead of being rejected; older ones are forgotten (0: none are kept). Each costs
  // a joint marginal: a pass spends at most 50 ms on them, the newest removed poses first (under
  // a sustained overload some are removed without).
  struct PoseWindow {
    int keep_poses = 0;
    double keyframe_spacing_m = 1.0;
    int every_updates = 100;
    bool sparse_summaries = true;
    int summary_parents = 2;
    int keep_aliases = 2000;
  };
  PoseWindow window = {};
  // Per robot (by name): its own keep_poses and keyframe_spacing_m in place of window's (a
  // robot whose map must stay whole next to ones on a window, or the other way round); checked
  // every window.every_updates updates.
  struct RobotWindow {
    std::string robot;
    PoseWindow window;
  };
  std::vector<RobotWindow> robot_windows = {};
  // The window that applies to `robot`.
  const PoseWindow& WindowOf(const std::string& robot) const;

  // Reduced pose graph (server/estimator/reduced_graph.h): a robot's new pose within
  // distance_m and angle_deg of a pose already in the map (any robot's) is not added as a node
  // but held relative to its robot's last node, and its measurements composed onto that node,
  // so revisiting a mapped area grows neither the graph nor memory. distance_m 0 = off (every
  // pose a node); > 0 also spaces a robot's nodes at least that far. angle_deg in (0, 180].
  // A robot keeps its last keep_aliases aliases (>= 1) for messages that name them (a loop
  // closure to a recent pose); older ones are forgotten (such a message is rejected as
  // naming an unknown pose).
  // link_mapped_landmarks: an alias's observation of a landmark already in the map, composed
  // onto the alias's node, adds a factor between them when they have none (true; each pair
  // once, so the factors of a fixed area stop growing once its nodes are linked to the
  // landmarks they see) or is left out (false: a revisit then adds no factors to landmarks, a
  // smaller graph, but the observations left out do not inform the map).
  struct ReducedGraph {
    double distance_m = 0.0;
    double angle_deg = 30.0;
    int keep_aliases = 2000;
    bool link_mapped_landmarks = true;
  };
  ReducedGraph reduced = {};
  // Per robot (by name): its own distance_m and angle_deg in place of reduced's.
  struct RobotReduced {
    std::string robot;
    ReducedGraph reduced;
  };
  std::vector<RobotReduced> robot_reduced = {};
  // The reduced graph that applies to `robot`.
  const ReducedGraph& ReducedOf(const std::string& robot) const;

  // Map shards (docs/SCALING.md): the robots this slamd owns; the daemon sets it from the
  // config's shards section. Unsharded by default.
  ShardMap shards = {};

  core::Status Validate() const;
};

}  // namespace slamd::server
