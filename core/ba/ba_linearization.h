// BaLinearization: the bundle adjuster's unknowns and the linearisation of a reconstruction's
// observations (internal to core/ba): residuals and Jacobians per observation, scaled by
// √ρ'(|r_o|²) for a robust kernel, and the blocks U_i = Σ Jc_oᵀ Jc_o (camera), diag(V_j) and the
// gradients gc_i = Σ Jc_oᵀ r_o, gp_j = Σ Jp_oᵀ r_o that point elimination (ba_problem.h) uses.
// Cal: the calibration model; kRefineCal: whether it is part of each camera's unknowns
// (D = 6 + its dimension) or not (D = 6). Pose unknowns are right perturbations T_wc·Exp(ξ).
// Shared calibrations (kRefineCal false, `shared` set): each intrinsics' calibration is one
// unknown of its own, common to its images; its Jacobians Jk_o (2 x dim) are kept per
// observation and summed per camera (Jc_oᵀ Jk_o, Jk_oᵀ Jk_o, Jk_oᵀ r_o) for the border of the
// reduced system (calibration_border.h).
// A refined calibration moves only as its model allows (CalibrationBasis: its Jacobian is taken
// per refined parameter, Jk·P, and its step is P·δ), so that a COLMAP model can be written back.
// Threads: each pass splits the points (or cameras) into one chunk per thread.
#pragma once

#include <cmath>
#include <numeric>
#include <vector>

#include "core/ba/ba_observations.h"
#include "core/base/check.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/camera.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core::internal {

// How refined calibrations are unknowns besides kRefineCal (BundleAdjusterParams).
struct CalibrationUnknowns {
  bool shared = false;           // one unknown per intrinsics, common to its images
  bool principal_point = false;  // refine the principal point (CalibrationBasis)
};

template <typename Cal, bool kRefineCal>
class BaLinearization : public BaObservations {
 public:
  static constexpr int kD = 6 + (kRefineCal ? Cal::kDim : 0);
  using CameraJacobian = Eigen::Matrix<double, 2, kD>;
  using CameraVector = Eigen::Matrix<double, kD, 1>;
  using CameraMatrix = Eigen::Matrix<double, kD, kD>;
  using CameraPoint = Eigen::Matrix<double, kD, 3>;
  static constexpr int kC = Cal::kDim;
  using CalMatrix = Eigen::Matrix<double, kC, kC>;
  using CalVector = Eigen::Matrix<double, kC, 1>;
  using CameraCal = Eigen::Matrix<double, kD, kC>;

  // The unknowns.
  struct State {
    std::vector<Pose3> poses;  // per image
    std::vector<Cal> cals;     // per image (a copy of its intrinsics' calibration)
    std::vector<Point3> points;
  };

  // `position[i]`: image i's place in the reduced camera system (a permutation).
  // `cal`: how calibrations are refined (shared only without kRefineCal).
  BaLinearization(const Reconstruction& r, const RobustKernel& robust, std::vector<int> position,
                  WorkerPool* pool, CalibrationUnknowns cal = {})
      : BaObservations(r, std::move(position), pool), robust_(robust) {
    SLAMD_CHECK(!(cal.shared && kRefineCal)) << "calibrations are either per camera or shared";
    if (cal.shared) {
      // Shared unknowns for the intrinsics that some image uses, in the intrinsics' order.
      std::vector<int> index(r.intrinsics.size(), -1);
      for (const SfmImage& image : r.images) index[image.intrinsics] = 0;
      for (int& k : index) k = k == 0 ? num_shared_++ : -1;
      for (const SfmImage& image : r.images) shared_of_.push_back(index[image.intrinsics]);
      jk_.resize(num_observations());
      uk_.resize(num_cameras());
      kk_.resize(num_cameras());
      gk_.resize(num_cameras());
    }
    for (const SfmImage& image : r.images) {
      cal_basis_.push_back(CalibrationBasis(r.intrinsics[image.intrinsics], cal.principal_point));
    }
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
  // `cals`: write the calibrations (refined per camera or shared), else only poses and points.
  static void WriteBack(const State& x, bool cals, Reconstruction* r) {
    for (size_t i = 0; i < r->images.size(); ++i) {
      r->images[i].pose = x.poses[i];
      if (cals) r->intrinsics[r->images[i].intrinsics].calibration = x.cals[i];
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
    // Shared calibrations: each chunk sums its observations' camera terms (few cameras: they stay
    // in cache, where a pass per camera would gather the observations from all over memory).
    struct SharedSums {
      std::vector<CameraCal> uk;
      std::vector<CalMatrix> kk;
      std::vector<CalVector> gk;
    };
    std::vector<SharedSums> sums(shared() ? Chunks() : 0);
    for (SharedSums& s : sums) {
      s.uk.assign(num_cameras(), CameraCal::Zero());
      s.kk.assign(num_cameras(), CalMatrix::Zero());
      s.gk.assign(num_cameras(), CalVector::Zero());
    }
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
                                       kRefineCal || shared() ? &h_cal : nullptr);
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
          if (kRefineCal || shared()) h_cal = h_cal * cal_basis_[i];
          jc_[o].template leftCols<6>() = scale * h_pose;
          if constexpr (kRefineCal) jc_[o].template rightCols<Cal::kDim>() = scale * h_cal;
          jp_[o] = scale * h_point;
          if (shared()) {
            jk_[o] = scale * h_cal;
            sums[t].uk[i].noalias() += jc_[o].transpose() * jk_[o];
            sums[t].kk[i].noalias() += jk_[o].transpose() * jk_[o];
            sums[t].gk[i].noalias() += jk_[o].transpose() * r;
          }
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
    if (shared()) {
      uk_ = std::move(sums[0].uk), kk_ = std::move(sums[0].kk), gk_ = std::move(sums[0].gk);
      for (size_t t = 1; t < sums.size(); ++t) {
        for (int i = 0; i < num_cameras(); ++i) {
          uk_[i] += sums[t].uk[i], kk_[i] += sums[t].kk[i], gk_[i] += sums[t].gk[i];
        }
      }
    }
    return 0.5 * Sum(cost);
  }

  // The largest entry of the gradient Jᵀr (of ½ Σ ρ).
  double GradientMaxNorm() const {
    double m = 0.0;
    for (const CameraVector& g : gc_) m = std::max(m, g.cwiseAbs().maxCoeff());
    for (const Vector3& g : gp_) m = std::max(m, g.cwiseAbs().maxCoeff());
    if (shared()) m = std::max(m, SharedGradient().cwiseAbs().maxCoeff());
    return m;
  }

  bool shared() const { return num_shared_ > 0; }
  // Camera i's calibration change per refined parameter (CalibrationBasis).
  const CalMatrix& cal_basis(int i) const { return cal_basis_[i]; }
  // Shared calibration unknowns (0 unless `shared`), kC each; camera i's is shared_of(i).
  int num_shared() const { return num_shared_; }
  int shared_of(int i) const { return shared_of_[i]; }
  int shared_dim() const { return kC * num_shared_; }

 protected:
  // Σ Jk_oᵀ r_o per shared calibration (shared_dim() entries).
  Eigen::VectorXd SharedGradient() const {
    Eigen::VectorXd g = Eigen::VectorXd::Zero(shared_dim());
    for (int i = 0; i < num_cameras(); ++i) g.template segment<kC>(kC * shared_of_[i]) += gk_[i];
    return g;
  }

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
  std::vector<CalMatrix> cal_basis_;  // per camera
  // Shared calibrations: per camera, its unknown; per observation Jk_o; per camera Σ Jc_oᵀ Jk_o,
  // Σ Jk_oᵀ Jk_o and Σ Jk_oᵀ r_o.
  int num_shared_ = 0;
  std::vector<int> shared_of_;
  std::vector<Eigen::Matrix<double, 2, kC>> jk_;
  std::vector<CameraCal> uk_;
  std::vector<CalMatrix> kk_;
  std::vector<CalVector> gk_;
};

}  // namespace slamd::core::internal
