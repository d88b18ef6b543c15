#include "core/ba/ba_observations.h"

#include <algorithm>
#include <numeric>

#include "core/base/check.h"
#include "core/linear/ordering.h"

namespace slamd::core::internal {

Result<std::vector<int>> CameraPositions(const Reconstruction& r, bool fill_reducing) {
  const int n = static_cast<int>(r.images.size());
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  if (!fill_reducing) return identity;
  std::vector<std::vector<int>> cameras_of(r.points.size());
  for (const SfmObservation& o : r.observations) cameras_of[o.point].push_back(o.image);
  FactorIncidence incidence;
  for (const std::vector<int>& cams : cameras_of) incidence.AddFactor(cams);
  Result<std::vector<int>> order = ColamdOrdering(n, incidence);
  if (!order.ok()) return order.status();
  return InversePermutation(order.value());
}

BaObservations::BaObservations(const Reconstruction& r, std::vector<int> position, WorkerPool* pool)
    : position_(std::move(position)), pool_(pool) {
  const int num_points = static_cast<int>(r.points.size());
  const int num_images = static_cast<int>(r.images.size());
  point_start_.assign(num_points + 1, 0);
  for (const SfmObservation& o : r.observations) ++point_start_[o.point + 1];
  for (int j = 0; j < num_points; ++j) point_start_[j + 1] += point_start_[j];
  const size_t num_obs = r.observations.size();
  camera_.resize(num_obs);
  measured_.resize(num_obs);
  std::vector<int> fill(point_start_.begin(), point_start_.end() - 1);
  for (const SfmObservation& o : r.observations) {
    const int at = fill[o.point]++;
    camera_[at] = o.image;
    measured_[at] = o.uv;
  }
  // Within a point, observations in ascending camera position: a pair (a, c), a before c,
  // lands in the upper block triangle of S.
  std::vector<int> order;
  for (int j = 0; j < num_points; ++j) {
    const int begin = point_start_[j], end = point_start_[j + 1];
    order.resize(end - begin);
    for (int k = 0; k < end - begin; ++k) order[k] = begin + k;
    std::sort(order.begin(), order.end(),
              [&](int a, int c) { return position_[camera_[a]] < position_[camera_[c]]; });
    std::vector<int> cams(end - begin);
    std::vector<Vector2> uvs(end - begin);
    for (int k = 0; k < end - begin; ++k) cams[k] = camera_[order[k]], uvs[k] = measured_[order[k]];
    std::copy(cams.begin(), cams.end(), camera_.begin() + begin);
    std::copy(uvs.begin(), uvs.end(), measured_.begin() + begin);
  }
  camera_obs_start_.assign(num_images + 1, 0);
  for (int c : camera_) ++camera_obs_start_[c + 1];
  for (int i = 0; i < num_images; ++i) camera_obs_start_[i + 1] += camera_obs_start_[i];
  camera_obs_.resize(num_obs);
  std::vector<int> cam_fill(camera_obs_start_.begin(), camera_obs_start_.end() - 1);
  for (size_t o = 0; o < num_obs; ++o) camera_obs_[cam_fill[camera_[o]]++] = static_cast<int>(o);
  // One chunk of points per thread, of about the same number of observations.
  const int chunks = pool_->helpers() + 1;
  point_chunk_.assign(1, 0);
  for (int t = 1; t < chunks; ++t) {
    const int target = static_cast<int>(num_obs * t / chunks);
    const int j = static_cast<int>(
        std::lower_bound(point_start_.begin(), point_start_.end(), target) - point_start_.begin());
    point_chunk_.push_back(std::max(point_chunk_.back(), std::min(j, num_points)));
  }
  point_chunk_.push_back(num_points);
  // One share of S's rows per thread, of about the same number of pair blocks: observation k of
  // a point seen m times adds m − k of them to its camera's row.
  std::vector<long> row_weight(num_images + 1, 0);
  for (int j = 0; j < num_points; ++j) {
    const int m = point_start_[j + 1] - point_start_[j];
    for (int k = 0; k < m; ++k) row_weight[position_[camera_[point_start_[j] + k]] + 1] += m - k;
  }
  for (int i = 0; i < num_images; ++i) row_weight[i + 1] += row_weight[i];
  row_share_.assign(1, 0);
  for (int t = 1; t < chunks; ++t) {
    const long target = row_weight.back() * t / chunks;
    const int i = static_cast<int>(std::lower_bound(row_weight.begin(), row_weight.end(), target) -
                                   row_weight.begin());
    row_share_.push_back(std::max(row_share_.back(), std::min(i, num_images)));
  }
  row_share_.push_back(num_images);
}

std::vector<std::vector<int>> BaObservations::CoVisibility() const {
  std::vector<std::vector<int>> rows(num_cameras());
  for (int i = 0; i < num_cameras(); ++i) rows[i].push_back(i);
  for (int j = 0; j < num_points(); ++j) {
    for (int a = point_start_[j]; a < point_start_[j + 1]; ++a) {
      for (int c = a + 1; c < point_start_[j + 1]; ++c) {
        rows[position_[camera_[a]]].push_back(position_[camera_[c]]);
      }
    }
  }
  for (std::vector<int>& row : rows) {
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
  }
  return rows;
}

void BaObservations::ForEachPointChunk(const std::function<void(int, int, int)>& fn) const {
  pool_->Run(Chunks(), [&](int t) { fn(t, point_chunk_[t], point_chunk_[t + 1]); });
  pool_->Wait();
}

void BaObservations::ForEachCameraChunk(const std::function<void(int, int)>& fn) const {
  const int n = num_cameras(), chunks = Chunks();
  pool_->Run(chunks, [&](int t) { fn(n * t / chunks, n * (t + 1) / chunks); });
  pool_->Wait();
}

void BaObservations::ForEachRowShare(const std::function<void(int, int)>& fn) const {
  pool_->Run(Chunks(), [&](int t) { fn(row_share_[t], row_share_[t + 1]); });
  pool_->Wait();
}

void BaObservations::IndexBlocks(const ReducedCameraMatrix& s) {
  pair_start_.assign(num_points() + 1, 0);
  pair_block_.clear();
  for (int j = 0; j < num_points(); ++j) {
    for (int a = point_start_[j]; a < point_start_[j + 1]; ++a) {
      for (int c = a; c < point_start_[j + 1]; ++c) {
        const long blk = s.BlockIndex(position_[camera_[a]], position_[camera_[c]]);
        SLAMD_CHECK(blk >= 0) << "S lacks the block of cameras " << camera_[a] << ", "
                              << camera_[c];
        pair_block_.push_back(blk);
      }
    }
    pair_start_[j + 1] = static_cast<long>(pair_block_.size());
  }
}

}  // namespace slamd::core::internal
