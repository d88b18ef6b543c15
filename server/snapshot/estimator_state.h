// EstimatorState: everything an Estimator is, as plain values, so that a snapshot can be
// written from an immutable copy on a background thread and an Estimator rebuilt from it at
// recovery (server/snapshot/state_codec.h turns it into bytes). Factors are shared immutable
// objects, so a copy is cheap: O(variables + factors) pointers and values.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/factors/factor.h"
#include "core/factors/values.h"
#include "server/messages/inbound.h"
#include "server/snapshot/estimate_snapshot.h"

namespace slamd::server {

// A robot as the estimator keeps it (by robot id), and as snapshots store it.
struct RobotState {
  bool anchored = false;  // has a pose in the graph (or staged)
  std::uint64_t newest = 0;
  // utime of its newest applied message, and when that message was received [µs, steady clock
  // of this process: not stored in snapshots].
  std::int64_t measurement_utime = 0;
  std::int64_t received_us = 0;
  core::Variable published;  // the newest pose's estimate in the last EstimateSnapshot
  std::uint64_t published_index = 0;
  std::int64_t moved_sequence = 0;  // the update sequence that last moved it
};

// A pose the reduced pose graph holds as no node (server/estimator/reduced_graph.h): anchor ∘
// offset, the anchor a pose node, the offset's covariance in its chart (right perturbation).
struct PoseAlias {
  core::Key anchor = 0;
  core::Variable offset;  // Pose2 or Pose3
  Eigen::MatrixXd covariance;
};

struct EstimatorState {
  std::int64_t update_sequence = 0;
  std::vector<core::FactorPtr> factors = {};  // the current factors, in solver index order
  core::Values linearization_point;           // θ (a restore re-solves δ there)

  // A retractable measurement (remove_factor_t) and its factor's position in `factors`.
  struct Applied {
    char type = 0;  // 'o' odometry, 'l' landmark, 'c' loop closure, 'p' prior, 'f' frame feature
    core::Key a = 0, b = 0;
    int kind = 0;
    int factor = 0;
    core::Key first = 0;
    int dim = 0;
  };
  std::vector<Applied> applied = {};

  struct Robot {
    std::string name;
    std::uint8_t id = 0;
    RobotState state;
  };
  std::vector<Robot> robots = {};  // registration order

  struct HeldMessage {
    Inbound message;
    int waited = 0;
  };
  std::vector<HeldMessage> held = {};
  // The cameras, as the camera_info_t messages that made them (utime 0), and the observations
  // of camera landmarks not determined yet: one-feature frame_observations_t, `waited` the
  // updates their landmark has waited.
  std::vector<Inbound> cameras = {};
  std::vector<HeldMessage> track_observations = {};

  // The reduced pose graph: poses held as aliases, and the measurements it composed onto their
  // anchors or absorbed (their identity and core::MeasurementDigest, for duplicates).
  std::vector<std::pair<core::Key, PoseAlias>> aliases = {};
  struct Merged {
    char type = 0;
    core::Key a = 0, b = 0;
    int kind = 0;
    std::uint64_t digest = 0;
  };
  std::vector<Merged> merged = {};

  EstimatorCounters counters;
  std::int64_t num_factors = 0;
  std::int64_t residual_dimension = 0;
  std::vector<core::Key> shard_boundary = {};  // a map shard's boundary so far
};

}  // namespace slamd::server
