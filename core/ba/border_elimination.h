// BaBorderedProblem: the bundle adjuster's problem (ba_problem.h) with the elimination of the
// points into the border that calibrations shared by several images add to the reduced system
// (calibration_border.h). Internal to core/ba.
//
// With Jk_o the shared calibration's Jacobian of observation o (ba_linearization.h) and
// B_jk = Σ_{o of j through calibration k} Jk_oᵀ Jp_o (notation of ba_problem.h):
//   E = Σ_o Jc_oᵀ Jk_o − Σ_j W_j V_j⁻¹ B_jᵀ,  F = Σ Jk_oᵀ Jk_o + λ·diag − Σ_j B_j V_j⁻¹ B_jᵀ,
//   bk = −gk + Σ_j B_j V_j⁻¹ gp_j,
// with V_j⁻¹ through the points' factors R_j of the last EliminatePoints.
#pragma once

#include <algorithm>
#include <vector>

#include "core/ba/ba_problem.h"
#include "core/ba/calibration_border.h"

namespace slamd::core::internal {

template <typename Cal, bool kRefineCal>
class BaBorderedProblem : public BaProblem<Cal, kRefineCal> {
  using Base = BaProblem<Cal, kRefineCal>;

 public:
  using Base::Base;
  static constexpr int kD = Base::kD;
  static constexpr int kC = Base::kC;
  using typename Base::CameraPoint;

  // The border of the shared calibrations with the damping and the points' factors of the last
  // EliminatePoints. Each thread sums its points into its own copy.
  void EliminateBorder(CalibrationBorder* border) const {
    const int n = num_cameras(), m = this->shared_dim();
    std::vector<CalibrationBorder> partial(Chunks());
    ForEachPointChunk([&](int t, int j_begin, int j_end) {
      CalibrationBorder& out = partial[t];
      out.SetZero(kD * n, m);
      std::vector<CameraPoint> a;                    // per observation: Jc_oᵀ Jp_o R_j⁻¹
      std::vector<int> ks;                           // the point's shared calibrations
      std::vector<Eigen::Matrix<double, kC, 3>> bs;  // and B_jk R_j⁻¹ for each
      for (int j = j_begin; j < j_end; ++j) {
        const int begin = point_start_[j], end = point_start_[j + 1];
        const Matrix3& R = r_factor_[j];
        a.resize(end - begin);
        ks.clear();
        bs.clear();
        for (int o = begin; o < end; ++o) {
          const Matrix32 zt = SolveFactorTransposed(R, Matrix32(jp_[o].transpose()));
          a[o - begin].noalias() = jc_[o].transpose().lazyProduct(zt.transpose());
          const int k = shared_of_[camera_[o]];
          const auto found = std::find(ks.begin(), ks.end(), k);
          if (found == ks.end()) {
            ks.push_back(k);
            bs.emplace_back(jk_[o].transpose() * zt.transpose());
          } else {
            bs[found - ks.begin()].noalias() += jk_[o].transpose() * zt.transpose();
          }
        }
        const Vector3 q = SolveFactorTransposed(R, gp_[j]);
        for (size_t x = 0; x < ks.size(); ++x) {
          out.b.template segment<kC>(kC * ks[x]).noalias() += bs[x] * q;
          for (size_t y = 0; y < ks.size(); ++y) {
            out.f.template block<kC, kC>(kC * ks[x], kC * ks[y]).noalias() -=
                bs[x] * bs[y].transpose();
          }
          for (int o = begin; o < end; ++o) {
            out.e.template block<kD, kC>(kD * position_[camera_[o]], kC * ks[x]).noalias() -=
                a[o - begin] * bs[x].transpose();
          }
        }
      }
    });
    *border = std::move(partial[0]);
    for (int t = 1; t < Chunks(); ++t) {
      border->e += partial[t].e;
      border->f += partial[t].f;
      border->b += partial[t].b;
    }
    // The cameras' own terms, and the calibrations' damping (Marquardt's, as U's and V's).
    Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(m);
    for (int i = 0; i < n; ++i) {
      const int k = shared_of_[i];
      border->e.template block<kD, kC>(kD * position_[i], kC * k) += uk_[i];
      border->f.template block<kC, kC>(kC * k, kC * k) += kk_[i];
      border->b.template segment<kC>(kC * k) -= gk_[i];
      diagonal.template segment<kC>(kC * k) += kk_[i].diagonal();
    }
    border->f.diagonal() += lambda_ * ClampedDiagonal(diagonal);
  }

 private:
  using Base::camera_;
  using Base::Chunks;
  using Base::ForEachPointChunk;
  using Base::gk_;
  using Base::gp_;
  using Base::jc_;
  using Base::jk_;
  using Base::jp_;
  using Base::kk_;
  using Base::lambda_;
  using Base::num_cameras;
  using Base::point_start_;
  using Base::position_;
  using Base::r_factor_;
  using Base::shared_of_;
  using Base::uk_;
};

}  // namespace slamd::core::internal
