#include "core/ba/calibration_border.h"

#include <Eigen/Cholesky>

namespace slamd::core::internal {

Status SolveBordered(const MultiSolve& solve_s, const CalibrationBorder& border,
                     const Eigen::VectorXd& b, Eigen::VectorXd* dc, Eigen::VectorXd* dk) {
  const int n = static_cast<int>(b.size()), m = border.dim();
  Eigen::MatrixXd rhs(n, m + 1), y;
  rhs.leftCols(m) = border.e;
  rhs.col(m) = b;
  SLAMD_RETURN_IF_ERROR(solve_s(rhs, &y));
  // G = F − Eᵀ S⁻¹ E: the calibrations' system with the poses eliminated.
  Eigen::MatrixXd g = border.f;
  g.noalias() -= border.e.transpose() * y.leftCols(m);
  const Eigen::LLT<Eigen::MatrixXd> llt(g.selfadjointView<Eigen::Lower>());
  if (llt.info() != Eigen::Success) {
    return NumericalFailure("reduced system of the shared calibrations not positive definite");
  }
  *dk = llt.solve(border.b - border.e.transpose() * y.col(m));
  *dc = y.col(m) - y.leftCols(m) * *dk;
  return Status::Ok();
}

void BorderedProduct(
    const std::function<void(const Eigen::VectorXd&, Eigen::VectorXd*)>& multiply_s,
    const CalibrationBorder& border, const Eigen::VectorXd& x, Eigen::VectorXd* y) {
  const int m = border.dim(), n = static_cast<int>(x.size()) - m;
  Eigen::VectorXd sx;
  multiply_s(x.head(n), &sx);
  y->resize(x.size());
  y->head(n) = sx + border.e * x.tail(m);
  y->tail(m) = border.e.transpose() * x.head(n) + border.f * x.tail(m);
}

}  // namespace slamd::core::internal
