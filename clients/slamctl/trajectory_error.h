// Absolute trajectory error (ATE) of an estimate against a ground truth, as `slamctl bench
// --ground-truth` reports it (Sturm et al., "A benchmark for the evaluation of RGB-D SLAM
// systems", IROS 2012, §V-B, without the time association).
//
// The estimate is first aligned to the truth by the rigid transform (rotation R, translation t; no
// scale) that minimises Σ_i |truth_i − (R·est_i + t)|² over the positions of the poses present in
// both (the closed form of Horn 1987 / Umeyama 1991 with a proper rotation, det R = +1: SE(2) in
// 2D, SE(3) in 3D). The ATE is then the RMSE and the maximum of |truth_i − (R·est_i + t)| in
// metres. Only positions enter (the standard ATE); orientations are ignored.
//
// Pure functions (no I/O) except ReadGroundTruth. Thread-compatible.
#pragma once

#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "core/base/status.h"
#include "core/factors/values.h"

namespace slamd::clients {

// truth ≈ R·estimate + t (R: d×d rotation, t: d-vector; d = 2 or 3).
struct RigidAlignment {
  Eigen::MatrixXd R;
  Eigen::VectorXd t;
};

// The least-squares rigid alignment of point set `estimate` onto `truth` (both d×n, column i of
// one corresponding to column i of the other, d = 2 or 3, n >= 1). With n = 1, or collinear
// points in 3D, the rotation is not unique; any minimiser is returned (identity R for n = 1).
// kInvalidArgument for mismatched or unsupported sizes or non-finite entries.
core::Result<RigidAlignment> AlignRigid(const Eigen::MatrixXd& estimate, const Eigen::MatrixXd& truth);

struct TrajectoryError {
  double rmse = 0.0;       // √(mean |truth_i − (R·est_i + t)|²), metres
  double max = 0.0;        // max_i |truth_i − (R·est_i + t)|, metres
  std::size_t poses = 0;   // poses compared (keys that are a pose in both)
  RigidAlignment alignment;
};

// The ATE over the keys holding a Pose2 (or a Pose3) in both `estimate` and `truth` (other keys,
// e.g. landmarks or poses of one side only, are ignored). kInvalidArgument when no pose is
// shared, when a key is a Pose2 in one and a Pose3 in the other, or for non-finite positions.
core::Result<TrajectoryError> AbsoluteTrajectoryError(const core::Values& estimate, const core::Values& truth);

// The true poses in `path`: a g2o file with VERTEX lines (e.g. `slamctl sim`'s
// world_groundtruth.g2o: the vertices are the truth), or an iSAM/g2o/TORO file of noise-free
// measurements without vertices (iSAM's *_groundtruth.txt), whose poses are composed along the
// edges from the lowest pose id at the identity (ReadDataset's composition; with noise-free
// measurements every path gives the same pose). Landmarks are dropped. Errors: ReadDataset's.
core::Result<core::Values> ReadGroundTruth(const std::string& path);

}  // namespace slamd::clients
