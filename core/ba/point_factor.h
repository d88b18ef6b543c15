// The triangular factor R of a point's damped 3x3 block V_j + λ·D_j (internal to core/ba): built
// by Givens rotations of the rows of the point's Jacobians rather than by Cholesky of the formed
// block, which would square its condition (ba_problem.h's EliminatePoints says where that
// mattered), and the substitutions that apply it. Fixed-size and inline: called per observation.
#pragma once

#include <cmath>

#include "core/geometry/eigen_types.h"

namespace slamd::core::internal {

// Rotates `row` into the upper-triangular R: RᵀR gains rowᵀrow.
inline void AppendRowToFactor(Eigen::Matrix<double, 1, 3> row, Matrix3* R) {
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

// Rᵀ X = B and R X = B for the upper-triangular R, by substitution (Eigen's triangular solvers
// take a dynamic-size path for these tiny systems).
template <typename B>
B SolveFactorTransposed(const Matrix3& R, const B& b) {
  B x;
  x.row(0) = b.row(0) / R(0, 0);
  x.row(1) = (b.row(1) - R(0, 1) * x.row(0)) / R(1, 1);
  x.row(2) = (b.row(2) - R(0, 2) * x.row(0) - R(1, 2) * x.row(1)) / R(2, 2);
  return x;
}
template <typename B>
B SolveFactor(const Matrix3& R, const B& b) {
  B x;
  x.row(2) = b.row(2) / R(2, 2);
  x.row(1) = (b.row(1) - R(1, 2) * x.row(2)) / R(1, 1);
  x.row(0) = (b.row(0) - R(0, 1) * x.row(1) - R(0, 2) * x.row(2)) / R(0, 0);
  return x;
}

}  // namespace slamd::core::internal
