// EstimateSnapshot: an immutable picture of the estimator after one update or refinement, the
// only thing the publisher (and later the query service) reads. Shared as
// shared_ptr<const EstimateSnapshot>; never modified after it is built.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/variables/variable.h"
#include "server/ingest/reject_reason.h"

namespace slamd::server {

struct EstimatorCounters {
  std::int64_t processed = 0;  // messages handed to Estimator::Process
  std::int64_t applied = 0;    // messages turned into factors (and variables)
  std::int64_t held = 0;       // messages put on hold at least once
  std::int64_t rejected = 0;   // stateful rejections (also counted per reason)
  // messages the graph held already (re-sent): acknowledged, neither applied nor rejected
  std::int64_t already_held = 0;
  std::int64_t updates = 0;  // Isam2::Update calls (one per Process with anything new)
  std::int64_t refinements = 0;
  std::int64_t rebuilds = 0;  // background rebuilds swapped in
  std::int64_t landmarks_dropped = 0;  // camera landmarks never determined (LandmarkTracks)
  std::int64_t removed_variables = 0;  // by the lifelong window (EstimatorParams::window)
  // New poses the reduced pose graph held as aliases of existing nodes (EstimatorParams::reduced)
  std::int64_t merged_poses = 0;
  // Measurements on aliases the reduced pose graph merged without their information: a
  // composed measurement on a pair of variables that has one, and, with
  // ReducedGraph::link_mapped_landmarks false, observations of landmarks in the map
  std::int64_t reduced_left_out = 0;
  std::array<std::int64_t, kNumRejectReasonCodes> rejects_by_reason = {};
};

struct RobotEstimate {
  std::string name;
  std::uint8_t id = 0;
  std::uint64_t pose_index = 0;  // newest (largest index) pose of the robot in the graph
  core::Variable pose;           // its estimate: Pose2 or Pose3
  // update_sequence of the last update/refinement that moved this robot's newest pose.
  std::int64_t moved_sequence = 0;
  // utime and transport receipt time [µs, steady clock] of the robot's newest applied message.
  std::int64_t measurement_utime = 0;
  std::int64_t received_us = 0;
};

struct EstimateSnapshot {
  // Bumped by every Isam2 update and every refinement that changed the estimate.
  std::int64_t update_sequence = 0;
  double chi2 = 0.0;
  // The update_sequence chi2 was computed at (it lags behind by at most
  // EstimatorParams::chi2_interval_s, and never once the estimate has settled). After a swap of
  // a background rebuild it may be the rebuilt solver's, computed on its helper thread over the
  // updates it had taken: the chi2 of another estimate of the map as of that update.
  std::int64_t chi2_sequence = 0;
  std::int64_t residual_dimension = 0;
  std::int64_t num_variables = 0;
  std::int64_t num_factors = 0;
  bool settled = true;  // the last refinement converged (or none was needed)
  int held_messages = 0;
  int landmark_tracks = 0;            // camera landmarks waiting to be determined
  int track_observations = 0;         // and their observations
  std::vector<RobotEstimate> robots;  // anchored robots only, in registration order
  EstimatorCounters counters;
};

}  // namespace slamd::server
