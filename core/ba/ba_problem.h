// BaProblem: the steps of one Levenberg-Marquardt iteration of the bundle adjuster with the points
// eliminated first (internal to core/ba), on top of the linearisation (ba_linearization.h).
//
// Notation (Triggs et al., "Bundle Adjustment — A Modern Synthesis", §6.1): for observation o of
// point j by camera i, Jc_o (2 x D) and Jp_o (2 x 3) are the Jacobians of its residual r_o
// (all three scaled by √ρ'(|r_o|²) for a robust kernel). Then
//   U_i = Σ Jc_oᵀ Jc_o,  V_j = Σ Jp_oᵀ Jp_o,  W_o = Jc_oᵀ Jp_o,  gc_i = Σ Jc_oᵀ r_o,
//   gp_j = Σ Jp_oᵀ r_o, and with the Levenberg-Marquardt damping λ·diag (Marquardt's scaling,
//   the diagonal clamped to [1e-6, 1e32] as Ceres does) added to U and V:
//   S = U − Σ_j W_j V_j⁻¹ W_jᵀ,  b = −gc + Σ_j W_j V_j⁻¹ gp_j,  S δc = b,
//   δp_j = V_j⁻¹ (−gp_j − Σ_o W_oᵀ δc_i),
// with V_j⁻¹ applied through a triangular factor R_j of the damped V_j computed from the rows of
// Jp (EliminatePoints says why).
// Cal: the calibration model; kRefineCal: whether it is part of each camera's unknowns
// (D = 6 + its dimension) or not (D = 6). Pose unknowns are right perturbations T_wc·Exp(ξ).
// Shared calibrations (BaLinearization's `shared`): BackSubstitute and Retract take their step;
// the border they add to the reduced system is eliminated by BaBorderedProblem
// (border_elimination.h).
//
// Threads: every pass splits the points (or cameras) into one chunk per thread, except the
// elimination, which splits the rows of S and b (ForEachRowShare). One owner drives the problem.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "core/ba/ba_linearization.h"
#include "core/ba/point_factor.h"
#include "core/ba/reduced_camera_matrix.h"
#include "core/factors/robust_kernel.h"
#include "core/geometry/camera.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core::internal {

// Marquardt's diagonal: diag(JᵀJ) clamped to [1e-6, 1e32] (no unknown left undamped).
template <typename Diagonal>
auto ClampedDiagonal(const Diagonal& d) {
  return d.cwiseMax(1e-6).cwiseMin(1e32).eval();
}
template <typename Cal, bool kRefineCal>
class BaProblem : public BaLinearization<Cal, kRefineCal> {
  using Base = BaLinearization<Cal, kRefineCal>;

 public:
  static constexpr int kD = Base::kD;
  using Base::num_cameras;
  using Base::num_points;
  static constexpr int kC = Base::kC;
  using typename Base::CameraMatrix;
  using typename Base::CameraPoint;
  using typename Base::CameraVector;
  using typename Base::State;

  BaProblem(const Reconstruction& r, const RobustKernel& robust, std::vector<int> position,
            WorkerPool* pool, CalibrationUnknowns cal = {})
      : Base(r, robust, std::move(position), pool, cal) {
    r_factor_.resize(this->num_points());
  }

  // Eliminates the points with damping λ: S (when `s` is set: every block; otherwise only the
  // diagonal blocks, into *diagonal) and b (positions order). Keeps V_j's factor for
  // BackSubstitute. `s` must have the pattern of CoVisibility(), and be the same every call.
  void EliminatePoints(double lambda, ReducedCameraMatrix* s, std::vector<CameraMatrix>* diagonal,
                       Eigen::VectorXd* b) {
    EliminatePoints(lambda, lambda, s, diagonal, b);
  }
  // The same with the points damped by point_lambda instead (covariances: cameras undamped).
  void EliminatePoints(double lambda, double point_lambda, ReducedCameraMatrix* s,
                       std::vector<CameraMatrix>* diagonal, Eigen::VectorXd* b) {
    const int n = num_cameras();
    b->resize(kD * n);
    if (s && pair_start_.empty()) IndexBlocks(*s);
    if (s) s->SetZero();
    if (diagonal) diagonal->resize(n);
    lambda_ = lambda;
    ForEachCameraChunk([&](int i_begin, int i_end) {
      for (int i = i_begin; i < i_end; ++i) {
        CameraMatrix damped = u_[i];
        damped.diagonal() += lambda * ClampedDiagonal(u_[i].diagonal());
        const int p = position_[i];
        if (s) {
          Eigen::Map<CameraMatrix>(s->Block(s->RowBegin(p))) = damped;
        } else {
          (*diagonal)[p] = damped;
        }
        b->template segment<kD>(kD * p) = -gc_[i];
      }
    });
    // Every share visits every point but adds only to its own rows of S and b (no locks, no
    // cache lines passed between cores): the rows of a point's pairs (a, c), a <= c, are its
    // observations' positions, ascending.
    ForEachRowShare([&](int row_begin, int row_end) {
      std::vector<CameraPoint> a;  // per observation of the point: A_o = Jc_oᵀ Jp_o R_j⁻¹
      for (int j = 0; j < num_points(); ++j) {
        const int begin = point_start_[j], m = point_start_[j + 1] - begin;
        int first = 0;  // this share's observations of the point: [first, last)
        while (first < m && position_[camera_[begin + first]] < row_begin) ++first;
        int last = first;
        while (last < m && position_[camera_[begin + last]] < row_end) ++last;
        if (first == last) continue;
        // R_j: the triangular factor of V_j + λ·D_j by Givens rotations of the rows of Jp (not
        // Cholesky of the formed V_j, which squares its condition: a point a few millimetres
        // in front of a camera gives V_j a condition of 1e10 and S indefinite through the
        // cancellation in U − W V⁻¹ Wᵀ).
        Matrix3 R = Matrix3::Zero();
        R.diagonal() = (point_lambda * ClampedDiagonal(v_diagonal_[j])).cwiseSqrt();
        for (int o = begin; o < begin + m; ++o) {
          for (int row = 0; row < 2; ++row) AppendRowToFactor(jp_[o].row(row), &R);
        }
        if (first == 0) r_factor_[j] = R;  // one writer: the share of the point's first row
        a.resize(m);
        for (int k = first; k < m; ++k) {
          // Z = Jp R⁻¹, so that W V⁻¹ Wᵀ = Σ (Jcᵀ Z)(Jcᵀ Z)ᵀ.
          const Matrix32 zt = SolveFactorTransposed(R, Matrix32(jp_[begin + k].transpose()));
          a[k].noalias() = jc_[begin + k].transpose().lazyProduct(zt.transpose());
        }
        const Vector3 q = SolveFactorTransposed(R, gp_[j]);
        // Pairs are listed k-major: (k, k..m-1) starts k·m − k(k−1)/2 after the point's first.
        long pair = s ? pair_start_[j] + first * m - first * (first - 1) / 2 : 0;
        for (int k = first; k < last; ++k) {
          const int i = position_[camera_[begin + k]];
          b->template segment<kD>(kD * i).noalias() += a[k] * q;
          if (s) {
            for (int c = k; c < m; ++c) {
              Eigen::Map<CameraMatrix>(s->Block(pair_block_[pair++])).noalias() -=
                  a[k].lazyProduct(a[c].transpose());
            }
          } else {
            (*diagonal)[i].noalias() -= a[k].lazyProduct(a[k].transpose());
          }
        }
      }
    });
  }

  // y = S x with the damping of the last EliminatePoints, without forming S (positions order).
  void MultiplyReduced(const Eigen::VectorXd& x, Eigen::VectorXd* y) const {
    const int n = num_cameras();
    std::vector<Eigen::VectorXd> partial(Chunks(), Eigen::VectorXd::Zero(kD * n));
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      Eigen::VectorXd& out = partial[t];
      for (int j = j_begin; j < j_end; ++j) {
        Vector3 wx = Vector3::Zero();  // W_jᵀ x
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const Vector2 jx = jc_[o] * x.template segment<kD>(kD * position_[camera_[o]]);
          wx.noalias() += jp_[o].transpose() * jx;
        }
        const Vector3 z = SolveDampedV(j, wx);
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const Vector2 jz = jp_[o] * z;
          out.template segment<kD>(kD * position_[camera_[o]]).noalias() -= jc_[o].transpose() * jz;
        }
      }
    });
    *y = partial[0];
    for (int t = 1; t < Chunks(); ++t) *y += partial[t];
    for (int i = 0; i < n; ++i) {
      CameraMatrix damped = u_[i];
      damped.diagonal() += lambda_ * ClampedDiagonal(u_[i].diagonal());
      const int p = position_[i];
      y->template segment<kD>(kD * p).noalias() += damped * x.template segment<kD>(kD * p);
    }
  }

  // The points' step from the cameras' (positions order) and the shared calibrations' (`dk`,
  // empty without them), and the model's predicted decrease of the cost, −(gᵀδ + ½|Jδ|²).
  double BackSubstitute(const Eigen::VectorXd& dc, const Eigen::VectorXd& dk,
                        std::vector<Vector3>* dp) const {
    // J_o δ of the cameras' and calibrations' unknowns.
    const auto camera_step = [&](int o) {
      Vector2 jx = jc_[o] * dc.template segment<kD>(kD * position_[camera_[o]]);
      if (this->shared())
        jx.noalias() += jk_[o] * dk.template segment<kC>(kC * shared_of_[camera_[o]]);
      return jx;
    };
    dp->resize(num_points());
    std::vector<double> model(Chunks(), 0.0);
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      double chunk_model = 0.0;  // stored once (see Cost)
      for (int j = j_begin; j < j_end; ++j) {
        Vector3 rhs = -gp_[j];
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          rhs.noalias() -= jp_[o].transpose() * camera_step(o);
        }
        const Vector3 d = SolveDampedV(j, rhs);
        (*dp)[j] = d;
        double m = -gp_[j].dot(d);
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const Vector2 jd = camera_step(o) + jp_[o] * d;
          m -= 0.5 * jd.squaredNorm();
        }
        chunk_model += m;
      }
      model[t] = chunk_model;
    });
    double m = Sum(model);
    for (int i = 0; i < num_cameras(); ++i) {
      m -= gc_[i].dot(dc.template segment<kD>(kD * position_[i]));
    }
    if (this->shared()) m -= this->SharedGradient().dot(dk);
    return m;
  }

  // x ⊕ δ: poses by right perturbation, calibrations and points by addition (`dk`: the shared
  // calibrations' step, empty without them; every image of one gets the same).
  State Retract(const State& x, const Eigen::VectorXd& dc, const Eigen::VectorXd& dk,
                const std::vector<Vector3>& dp) const {
    State y = x;
    for (int i = 0; i < num_cameras(); ++i) {
      const CameraVector d = dc.template segment<kD>(kD * position_[i]);
      y.poses[i] = x.poses[i].Retract(d.template head<6>());
      if constexpr (kRefineCal) {
        y.cals[i] = x.cals[i].Retract(this->cal_basis(i) * d.template tail<Cal::kDim>());
      } else if (this->shared()) {
        y.cals[i] =
            x.cals[i].Retract(this->cal_basis(i) * dk.template segment<kC>(kC * shared_of_[i]));
      }
    }
    for (int j = 0; j < num_points(); ++j) y.points[j] = x.points[j] + dp[j];
    return y;
  }

 protected:
  // What the steps use of the layout and the linearisation (members of a dependent base).
  using Base::camera_;
  using Base::Chunks;
  using Base::ForEachCameraChunk;
  using Base::ForEachPointChunk;
  using Base::ForEachRowShare;
  using Base::gc_;
  using Base::gp_;
  using Base::IndexBlocks;
  using Base::jc_;
  using Base::jk_;
  using Base::jp_;
  using Base::pair_block_;
  using Base::pair_start_;
  using Base::point_start_;
  using Base::position_;
  using Base::shared_of_;
  using Base::Sum;
  using Base::u_;
  using Base::v_diagonal_;

  // (V_j + λ·D_j)⁻¹ x with the factor of the last EliminatePoints.
  Vector3 SolveDampedV(int j, const Vector3& x) const {
    const Matrix3& R = r_factor_[j];
    return SolveFactor(R, SolveFactorTransposed(R, x));
  }

  std::vector<Matrix3> r_factor_;  // R_j of the last EliminatePoints: RᵀR = V_j + λ·D_j
  double lambda_ = 0.0;
};

}  // namespace slamd::core::internal
