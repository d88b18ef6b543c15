// CalibrationBorder: the rows and columns that calibrations shared by several images add to the
// bundle adjuster's reduced camera system (internal to core/ba). With the points eliminated the
// system over the camera poses δc and the shared calibrations δk is
//   [S  E] [δc]   [b ]
//   [Eᵀ F] [δk] = [bk],
// S the reduced camera matrix (poses only), E its coupling to the calibrations (dense: one
// calibration is seen by every camera that uses it), F the calibrations' own block. Few shared
// calibrations (a COLMAP camera per physical camera) keep the border narrow, so the exact solvers
// eliminate it last: G = F − Eᵀ S⁻¹ E, δk = G⁻¹ (bk − Eᵀ S⁻¹ b), δc = S⁻¹ (b − E δk), S solved
// for the border's width + 1 right-hand sides with one factorisation. Conjugate gradients run on
// the bordered system as a whole instead (BorderedProduct).
#pragma once

#include <functional>

#include "core/base/status.h"
#include "core/geometry/eigen_types.h"

namespace slamd::core::internal {

struct CalibrationBorder {
  Eigen::MatrixXd e;  // (pose unknowns) x (calibration unknowns), S's positions order
  Eigen::MatrixXd f;  // calibration unknowns squared, symmetric
  Eigen::VectorXd b;  // bk

  int dim() const { return static_cast<int>(f.rows()); }
  void SetZero(int pose_dim, int cal_dim) {
    e.setZero(pose_dim, cal_dim);
    f.setZero(cal_dim, cal_dim);
    b.setZero(cal_dim);
  }
};

// Solves the bordered system given a solver of S for several right-hand sides (columns) with one
// factorisation. kNumericalFailure when S's solve fails or G is not positive definite.
using MultiSolve = std::function<Status(const Eigen::MatrixXd& rhs, Eigen::MatrixXd* x)>;
Status SolveBordered(const MultiSolve& solve_s, const CalibrationBorder& border,
                     const Eigen::VectorXd& b, Eigen::VectorXd* dc, Eigen::VectorXd* dk);

// y = [S x_c + E x_k; Eᵀ x_c + F x_k] for x = [x_c; x_k], S applied by `multiply_s`.
void BorderedProduct(
    const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>& multiply_s,
    const CalibrationBorder& border, const Eigen::VectorXd& x, Eigen::VectorXd* y);

}  // namespace slamd::core::internal
