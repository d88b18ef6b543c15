#include "core/inference/partial_cholesky.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace slamd::core::internal {
namespace {

// Below this size the whole factorisation is one unblocked loop; above it, panels of kPanel
// columns are factored unblocked and the trailing matrix gets one Eigen rank-k update per panel.
constexpr int kUnblockedMaxSize = 64;
constexpr int kPanel = 32;

// Eliminates columns [c0, c1) of M, updating only columns [c0, update_end) of the trailing
// lower triangle (rows down to n). Returns the failing column or -1.
inline int EliminateColumns(double* M, int n, int ld, int c0, int c1, int update_end, double* ref,
                            double tol) {
  for (int j = c0; j < c1; ++j) {
    double* col_j = M + static_cast<long>(j) * ld;
    const double pivot = col_j[j];
    if (!(pivot > tol * ref[j])) return j;  // also catches NaN
    const double l = std::sqrt(pivot);
    col_j[j] = l;
    const double inv = 1.0 / l;
    // Scale column j (L_tj), and propagate the error bound: ref[t] += ref[j] (L_tj / L_jj)².
    const double weight = ref[j] * inv * inv;
    for (int i = j + 1; i < n; ++i) {
      col_j[i] *= inv;
      ref[i] += weight * col_j[i] * col_j[i];
    }
    // Rank-1 update of the lower triangle of columns (j, update_end).
    for (int c = j + 1; c < update_end; ++c) {
      const double a = col_j[c];
      if (a == 0.0) continue;  // structural zeros are common (sparse separator couplings)
      double* col_c = M + static_cast<long>(c) * ld;
      for (int i = c; i < n; ++i) col_c[i] -= a * col_j[i];
    }
  }
  return -1;
}

}  // namespace

int PartialCholeskyLower(double* M, int n, int ld, int k, double* ref, double tol) {
  if (n <= kUnblockedMaxSize) return EliminateColumns(M, n, ld, 0, k, n, ref, tol);
  using Stride = Eigen::OuterStride<>;
  for (int c0 = 0; c0 < k; c0 += kPanel) {
    const int c1 = std::min(k, c0 + kPanel);
    // Panel: the columns [c0, c1) from row c0 down, with the previous panels already applied.
    const int failed = EliminateColumns(M, n, ld, c0, c1, c1, ref, tol);
    if (failed >= 0) return failed;
    const int rest = n - c1;
    if (rest == 0) break;
    Eigen::Map<Eigen::MatrixXd, 0, Stride> trailing(M + static_cast<long>(c1) * ld + c1, rest, rest,
                                                    Stride(ld));
    Eigen::Map<const Eigen::MatrixXd, 0, Stride> panel(M + static_cast<long>(c0) * ld + c1, rest,
                                                       c1 - c0, Stride(ld));
    trailing.selfadjointView<Eigen::Lower>().rankUpdate(panel, -1.0);
  }
  return -1;
}

}  // namespace slamd::core::internal
