// BaProblem: the bundle adjuster's view of a reconstruction (internal to core/ba): the
// observations grouped by point, their linearisation, and the steps of one Levenberg-Marquardt
// iteration with the points eliminated first.
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
// (D = 6 + its dimension) or fixed (D = 6). Pose unknowns are right perturbations T_wc·Exp(ξ).
//
// Threads: every pass splits the points (or cameras) into one chunk per thread; a camera's rows of
// S and b are added to under its row lock. One owner drives the problem.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "core/ba/reduced_camera_matrix.h"
#include "core/base/check.h"
#include "core/base/worker_pool.h"
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
class BaProblem {
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
  BaProblem(const Reconstruction& r, const RobustKernel& robust, std::vector<int> position,
            WorkerPool* pool)
      : robust_(robust), position_(std::move(position)), pool_(pool) {
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
      for (int k = 0; k < end - begin; ++k)
        cams[k] = camera_[order[k]], uvs[k] = measured_[order[k]];
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
      const int j =
          static_cast<int>(std::lower_bound(point_start_.begin(), point_start_.end(), target) -
                           point_start_.begin());
      point_chunk_.push_back(std::max(point_chunk_.back(), std::min(j, num_points)));
    }
    point_chunk_.push_back(num_points);
    jc_.resize(num_obs);
    jp_.resize(num_obs);
    r_.resize(num_obs);
    v_diagonal_.resize(num_points);
    r_factor_.resize(num_points);
    gp_.resize(num_points);
    u_.resize(num_images);
    gc_.resize(num_images);
    row_locks_ = std::make_unique<std::atomic<bool>[]>(num_images);
    for (int i = 0; i < num_images; ++i) row_locks_[i].store(false);
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

  int num_cameras() const { return static_cast<int>(u_.size()); }
  int num_points() const { return static_cast<int>(v_diagonal_.size()); }
  int num_observations() const { return static_cast<int>(camera_.size()); }
  int position(int camera) const { return position_[camera]; }

  // The camera positions each camera shares a point with, upper triangle (ReducedCameraMatrix).
  std::vector<std::vector<int>> CoVisibility() const {
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
    ForEachPointChunk([&](int, int j_begin, int j_end) {
      std::vector<CameraPoint> a;  // per observation of the point: A_o = Jc_oᵀ Jp_o R_j⁻¹
      for (int j = j_begin; j < j_end; ++j) {
        // R_j: the triangular factor of V_j + λ·D_j by Givens rotations of the rows of Jp (not
        // Cholesky of the formed V_j, which squares its condition: a point a few millimetres
        // in front of a camera gives V_j a condition of 1e10 and S indefinite through the
        // cancellation in U − W V⁻¹ Wᵀ).
        Matrix3 R = Matrix3::Zero();
        R.diagonal() = (point_lambda * ClampedDiagonal(v_diagonal_[j])).cwiseSqrt();
        const int begin = point_start_[j], m = point_start_[j + 1] - begin;
        for (int o = begin; o < begin + m; ++o) {
          for (int row = 0; row < 2; ++row) AppendRow(jp_[o].row(row), &R);
        }
        r_factor_[j] = R;
        a.resize(m);
        for (int k = 0; k < m; ++k) {
          // Z = Jp R⁻¹, so that W V⁻¹ Wᵀ = Σ (Jcᵀ Z)(Jcᵀ Z)ᵀ.
          const Matrix32 zt = SolveTransposed(R, Matrix32(jp_[begin + k].transpose()));
          a[k].noalias() = jc_[begin + k].transpose().lazyProduct(zt.transpose());
        }
        const Vector3 q = SolveTransposed(R, gp_[j]);
        long pair = s ? pair_start_[j] : 0;
        for (int k = 0; k < m; ++k) {
          const int i = position_[camera_[begin + k]];
          LockRow(i);
          b->template segment<kD>(kD * i).noalias() += a[k] * q;
          if (s) {
            for (int c = k; c < m; ++c) {
              Eigen::Map<CameraMatrix>(s->Block(pair_block_[pair++])).noalias() -=
                  a[k].lazyProduct(a[c].transpose());
            }
          } else {
            (*diagonal)[i].noalias() -= a[k].lazyProduct(a[k].transpose());
          }
          UnlockRow(i);
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

  // The points' step from the cameras' (positions order), and the model's predicted decrease
  // of the cost, −(gᵀδ + ½|Jδ|²).
  double BackSubstitute(const Eigen::VectorXd& dc, std::vector<Vector3>* dp) const {
    dp->resize(num_points());
    std::vector<double> model(Chunks(), 0.0);
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      double chunk_model = 0.0;  // stored once (see Cost)
      for (int j = j_begin; j < j_end; ++j) {
        Vector3 rhs = -gp_[j];
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const Vector2 jx = jc_[o] * dc.template segment<kD>(kD * position_[camera_[o]]);
          rhs.noalias() -= jp_[o].transpose() * jx;
        }
        const Vector3 d = SolveDampedV(j, rhs);
        (*dp)[j] = d;
        double m = -gp_[j].dot(d);
        for (int o = point_start_[j]; o < point_start_[j + 1]; ++o) {
          const Vector2 jd =
              jc_[o] * dc.template segment<kD>(kD * position_[camera_[o]]) + jp_[o] * d;
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
    return m;
  }

  // x ⊕ δ: poses by right perturbation, calibrations and points by addition.
  State Retract(const State& x, const Eigen::VectorXd& dc, const std::vector<Vector3>& dp) const {
    State y = x;
    for (int i = 0; i < num_cameras(); ++i) {
      const CameraVector d = dc.template segment<kD>(kD * position_[i]);
      y.poses[i] = x.poses[i].Retract(d.template head<6>());
      if constexpr (kRefineCal) {
        y.cals[i] = x.cals[i].Retract(d.template tail<Cal::kDim>());
      }
    }
    for (int j = 0; j < num_points(); ++j) y.points[j] = x.points[j] + dp[j];
    return y;
  }

  // Runs fn(chunk, first point, end point) on each thread's chunk of points.
  void ForEachPointChunk(const std::function<void(int, int, int)>& fn) const {
    pool_->Run(Chunks(), [&](int t) { fn(t, point_chunk_[t], point_chunk_[t + 1]); });
    pool_->Wait();
  }

 private:
  int Chunks() const { return static_cast<int>(point_chunk_.size()) - 1; }
  void ForEachCameraChunk(const std::function<void(int, int)>& fn) const {
    const int n = num_cameras(), chunks = Chunks();
    pool_->Run(chunks, [&](int t) { fn(n * t / chunks, n * (t + 1) / chunks); });
    pool_->Wait();
  }
  // For each point, the index in S of each of its pairs of observations (a, c), a <= c.
  void IndexBlocks(const ReducedCameraMatrix& s) {
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
  // (V_j + λ·D_j)⁻¹ x with the factor of the last EliminatePoints.
  Vector3 SolveDampedV(int j, const Vector3& x) const {
    const Matrix3& R = r_factor_[j];
    return Solve(R, SolveTransposed(R, x));
  }
  // Rᵀ X = B and R X = B for an upper-triangular 3x3 R, by substitution (Eigen's triangular
  // solvers take a dynamic-size path for these tiny systems).
  template <typename B>
  static B SolveTransposed(const Matrix3& R, const B& b) {
    B x;
    x.row(0) = b.row(0) / R(0, 0);
    x.row(1) = (b.row(1) - R(0, 1) * x.row(0)) / R(1, 1);
    x.row(2) = (b.row(2) - R(0, 2) * x.row(0) - R(1, 2) * x.row(1)) / R(2, 2);
    return x;
  }
  template <typename B>
  static B Solve(const Matrix3& R, const B& b) {
    B x;
    x.row(2) = b.row(2) / R(2, 2);
    x.row(1) = (b.row(1) - R(1, 2) * x.row(2)) / R(1, 1);
    x.row(0) = (b.row(0) - R(0, 1) * x.row(1) - R(0, 2) * x.row(2)) / R(0, 0);
    return x;
  }
  // Rotates `row` into the upper-triangular R (Givens): RᵀR gains rowᵀrow.
  static void AppendRow(Eigen::Matrix<double, 1, 3> row, Matrix3* R) {
    for (int k = 0; k < 3; ++k) {
      if (row[k] == 0.0) continue;
      const double h = std::sqrt((*R)(k, k) * (*R)(k, k) + row[k] * row[k]);
      const double c = (*R)(k, k) / h, s = row[k] / h;
      for (int l = k; l < 3; ++l) {
        const double rkl = (*R)(k, l);
        (*R)(k, l) = c * rkl + s * row[l];
        row[l] = -s * rkl + c * row[l];
      }
    }
  }
  // A spin lock per camera row of S and b: threads eliminating different points may add to the
  // same row; contention is rare (two threads, the row held for one point's blocks).
  void LockRow(int i) {
    while (row_locks_[i].exchange(true, std::memory_order_acquire)) {
    }
  }
  void UnlockRow(int i) { row_locks_[i].store(false, std::memory_order_release); }
  static double Sum(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s;
  }

  const RobustKernel robust_;
  const std::vector<int> position_;
  WorkerPool* pool_;
  // Observations, point-major: point j's are [point_start_[j], point_start_[j+1]).
  std::vector<int> point_start_, camera_;
  std::vector<Vector2> measured_;
  std::vector<int> camera_obs_start_, camera_obs_;  // per camera, its observations
  std::vector<int> point_chunk_;                    // per thread, its first point
  std::vector<long> pair_start_, pair_block_;       // IndexBlocks
  // The linearisation.
  std::vector<CameraJacobian> jc_;
  std::vector<Matrix23> jp_;
  std::vector<Vector2> r_;
  std::vector<Vector3> v_diagonal_;  // diag(V_j)
  std::vector<Matrix3> r_factor_;    // R_j of the last EliminatePoints: RᵀR = V_j + λ·D_j
  std::vector<Vector3> gp_;
  std::vector<CameraMatrix> u_;
  std::vector<CameraVector> gc_;
  double lambda_ = 0.0;
  std::unique_ptr<std::atomic<bool>[]> row_locks_;
};

}  // namespace slamd::core::internal
