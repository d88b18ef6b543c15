// BaLinearization: the bundle adjuster's unknowns and the linearisation of a reconstruction's
// observations (internal to core/ba): residuals and Jacobians per observation, scaled by
// √ρ'(|r_o|²) for a robust kernel, and the blocks U_i = Σ Jc_oᵀ Jc_o (camera), diag(V_j) and the
// gradients gc_i = Σ Jc_oᵀ r_o, gp_j = Σ Jp_oᵀ r_o that point elimination (ba_problem.h) uses.
// Cal: the calibration model; kRefineCal: whether it is part of each camera's unknowns
// (D = 6 + its dimension) or fixed (D = 6). Pose unknowns are right perturbations T_wc·Exp(ξ).
// Threads: each pass splits the points (or cameras) into one chunk per thread.
#pragma once

#include <cmath>
#include <numeric>
#include <vector>

#include "core/ba/ba_observations.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/camera.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core::internal {

template <typename Cal, bool kRefineCal>
class BaLinearization : public BaObservations {
 public:
  static constexpr int kD = 6 + (kRefineCal ? Cal::kDim : 0);
  using CameraJacobian = Eigen::Matrix<double, 2, kD>;
  using CameraVector = Eigen::Matrix<double, kD, 1>;
  using CameraMatrix = Eigen::Matrix<double, kD, kD>;
  using CameraPoint = Eigen::Matrix<double, kD, 3>;

  // The unknowns.
  struct State {
    std::vector<Pose3> poses;  // per image
    std::vector<Cal> cals;     // per image (a copy of its intrinsics' calibration)
    std::vector<Point3> points;
  };

  // `position[i]`: image i's place in the reduced camera system (a permutation).
  BaLinearization(const Reconstruction& r, const RobustKernel& robust, std::vector<int> position,
                  WorkerPool* pool)
      : BaObservations(r, std::move(position), pool), robust_(robust) {
    jc_.resize(num_observations());
    jp_.resize(num_observations());
    r_.resize(num_observations());
    v_diagonal_.resize(num_points());
    gp_.resize(num_points());
    u_.resize(num_cameras());
    gc_.resize(num_cameras());
  }

  // The unknowns as `r` has them, and back.
  static State StateOf(const Reconstruction& r) {
    State x;
    for (const SfmImage& image : r.images) {
      x.poses.push_back(image.pose);
      x.cals.push_back(std::get<Cal>(r.intrinsics[image.intrinsics].calibration));
    }
    for (const SfmPoint& p : r.points) x.points.push_back(p.position);
    return x;
  }
  static void WriteBack(const State& x, Reconstruction* r) {
    for (size_t i = 0; i < r->images.size(); ++i) {
      r->images[i].pose = x.poses[i];
      if constexpr (kRefineCal) r->intrinsics[r->images[i].intrinsics].calibration = x.cals[i];
    }
    for (size_t j = 0; j < r->points.size(); ++j) r->points[j].position = x.points[j];
  }

  // ½ Σ ρ(|r_o|²) at `x`; *squared_error (when set) gets Σ |r_o|² and *behind the number of
  // observations whose point is at or behind its camera.
  double Cost(const State& x, double* squared_error = nullptr, int* behind = nullptr) const {
    std::vector<double> cost(Chunks(), 0.0), sq(Chunks(), 0.0);
    std::vector<int> back(Chunks(), 0);
    // Sums kept in locals and stored once: neighbouring entries of cost, sq, back share a cache
    // line, and writing them in the loop made two threads slower than one.
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      double c = 0.0, q = 0.0;
      int n = 0;
      for (int j = j_begin; j < j_end; ++j) {
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const int i = camera_[o];
          const Projection p = Project(x.poses[i], x.cals[i], x.points[j]);
          const double s = (p.uv - measured_[o]).squaredNorm();
          c += robust_.is_none() ? s : robust_.Cost(s);
          q += s;
          n += !p.in_front();
        }
      }
      cost[t] = c, sq[t] = q, back[t] = n;
    });
    if (squared_error) *squared_error = Sum(sq);
    if (behind) {
      *behind = 0;
      for (int b : back) *behind += b;
    }
    return 0.5 * Sum(cost);
  }

  // Residuals and Jacobians at `x` and the blocks U, V, gc, gp; returns the cost ½ Σ ρ.
  double Linearize(const State& x) {
    std::vector<double> cost(Chunks(), 0.0);
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      double chunk_cost = 0.0;  // stored once (see Cost)
      for (int j = j_begin; j < j_end; ++j) {
        Vector3 v = Vector3::Zero();  // diag(V_j)
        Vector3 g = Vector3::Zero();
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const int i = camera_[o];
          Matrix26 h_pose;
          Matrix23 h_point;
          CalibrationJacobian<Cal> h_cal;
          const Projection p = Project(x.poses[i], x.cals[i], x.points[j], &h_pose, &h_point,
                                       kRefineCal ? &h_cal : nullptr);
          Vector2 r = p.uv - measured_[o];
          const double s = r.squaredNorm();
          double scale = 1.0;
          if (!robust_.is_none()) {
            chunk_cost += robust_.Cost(s);
            scale = std::sqrt(robust_.Weight(s));
          } else {
            chunk_cost += s;
          }
          r *= scale;
          jc_[o].template leftCols<6>() = scale * h_pose;
          if constexpr (kRefineCal) jc_[o].template rightCols<Cal::kDim>() = scale * h_cal;
          jp_[o] = scale * h_point;
          r_[o] = r;
          v += jp_[o].colwise().squaredNorm().transpose();
          g.noalias() += jp_[o].transpose() * r;
        }
        v_diagonal_[j] = v;
        gp_[j] = g;
      }
      cost[t] = chunk_cost;
    });
    ForEachCameraChunk([&](int i_begin, int i_end) {
      for (int i = i_begin; i < i_end; ++i) {
        CameraMatrix u = CameraMatrix::Zero();
        CameraVector g = CameraVector::Zero();
        for (int k = camera_obs_start_[i]; k < camera_obs_start_[i + 1]; ++k) {
          const int o = camera_obs_[k];
          u.noalias() += jc_[o].transpose().lazyProduct(jc_[o]);
          g.noalias() += jc_[o].transpose() * r_[o];
        }
        u_[i] = u;
        gc_[i] = g;
      }
    });
    return 0.5 * Sum(cost);
  }

  // The largest entry of the gradient Jᵀr (of ½ Σ ρ).
  double GradientMaxNorm() const {
    double m = 0.0;
    for (const CameraVector& g : gc_) m = std::max(m, g.cwiseAbs().maxCoeff());
    for (const Vector3& g : gp_) m = std::max(m, g.cwiseAbs().maxCoeff());
    return m;
  }

 protected:
  static double Sum(const std::vector<double>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0);
  }

  const RobustKernel robust_;
  std::vector<CameraJacobian> jc_;
  std::vector<Matrix23> jp_;
  std::vector<Vector2> r_;
  std::vector<Vector3> v_diagonal_;  // diag(V_j)
  std::vector<Vector3> gp_;
  std::vector<CameraMatrix> u_;
  std::vector<CameraVector> gc_;
};

}  // namespace slamd::core::internal
