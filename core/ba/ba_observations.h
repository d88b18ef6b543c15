// BaObservations: how the bundle adjuster lays out a reconstruction's observations (internal to
// core/ba): grouped by point (each point's in ascending camera position, so that a pair of them
// lands in the upper block triangle of S) and listed per camera; the cameras' co-visibility (the
// pattern of S) and, once S exists, the index of each pair's block; one chunk of points per
// thread, of about the same number of observations; and one share of S's rows per thread, which
// only that thread adds to. (Threads adding to any row under per-row spin locks did not scale:
// the blocks of S moved between the cores' caches, and two threads took as long as one.)
#pragma once

#include <functional>
#include <vector>

#include "core/ba/reduced_camera_matrix.h"
#include "core/base/status.h"
#include "core/base/worker_pool.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core::internal {

// The cameras' places in the reduced camera system: with `fill_reducing`, an order for sparse
// Cholesky (COLAMD on the point-by-camera incidence, whose AᵀA has S's pattern); otherwise the
// images' own order.
Result<std::vector<int>> CameraPositions(const Reconstruction& r, bool fill_reducing);

class BaObservations {
 public:
  // `position[i]`: image i's place in the reduced camera system (a permutation); `pool` runs the
  // passes (its helpers + the caller: one chunk each).
  BaObservations(const Reconstruction& r, std::vector<int> position, WorkerPool* pool);

  int num_cameras() const { return static_cast<int>(camera_obs_start_.size()) - 1; }
  int num_points() const { return static_cast<int>(point_start_.size()) - 1; }
  int num_observations() const { return static_cast<int>(camera_.size()); }
  int position(int camera) const { return position_[camera]; }

  // The camera positions each camera shares a point with, upper triangle (ReducedCameraMatrix).
  std::vector<std::vector<int>> CoVisibility() const;

  // Runs fn(chunk, first point, end point) on each thread's chunk of points.
  void ForEachPointChunk(const std::function<void(int, int, int)>& fn) const;

 protected:
  int Chunks() const { return static_cast<int>(point_chunk_.size()) - 1; }
  // fn(first camera, end camera) on each thread's share of the cameras.
  void ForEachCameraChunk(const std::function<void(int, int)>& fn) const;
  // For each point, the index in S of each of its pairs of observations (a, c), a <= c.
  void IndexBlocks(const ReducedCameraMatrix& s);
  // fn(first position, end position) on each thread's share of the rows of S, of about the same
  // number of blocks to eliminate into.
  void ForEachRowShare(const std::function<void(int, int)>& fn) const;

  const std::vector<int> position_;
  WorkerPool* pool_;
  // Observations, point-major: point j's are [point_start_[j], point_start_[j+1]).
  std::vector<int> point_start_, camera_;
  std::vector<Vector2> measured_;
  std::vector<int> camera_obs_start_, camera_obs_;  // per camera, its observations
  std::vector<int> point_chunk_;                    // per thread, its first point
  std::vector<long> pair_start_, pair_block_;       // IndexBlocks
  std::vector<int> row_share_;                      // per thread, its first row position
};

}  // namespace slamd::core::internal
