#include "core/linear/partial_cholesky.h"

// Declared C linkage here: ATLAS's cblas.h (the system's when libceres-dev pulls in ATLAS) has no
// extern "C" guard of its own, OpenBLAS's and the reference one do (nesting is harmless).
extern "C" {
#include <cblas.h>
}

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "core/linear/blas_lock.h"

namespace slamd::core::internal {
namespace {

// Below this size the whole factorisation is one unblocked loop; above it, panels of kPanel
// columns are factored unblocked and the trailing matrix gets one Eigen rank-k update per panel.
constexpr int kUnblockedMaxSize = 64;
constexpr int kPanel = 32;
// A trailing update at least this wide goes to the BLAS's dsyrk (Debian's OpenBLAS picks kernels
// for the CPU's vector width at run time: AVX2/AVX-512 with FMA where this build targets SSE2),
// a smaller one to Eigen, for which the call and the BLAS's blocking cost more than they save.
constexpr int kBlasMinSize = 64;

// Applies columns x[0..w) (already final L columns, with multipliers a[q] = x[q][c]) to column c
// of the lower triangle, rows [c, n). Each entry receives the updates in increasing column order,
// exactly as w successive rank-1 updates would, so the result is bitwise the same; one pass over
// the target column instead of w saves loads/stores.
inline void UpdateColumn(double* col_c, int c, int n, const double* const* x, const double* a,
                         int w) {
  bool all_nonzero = true;
  for (int q = 0; q < w; ++q) all_nonzero = all_nonzero && a[q] != 0.0;
  if (w == 4 && all_nonzero) {
    const double *x0 = x[0], *x1 = x[1], *x2 = x[2], *x3 = x[3];
    const double a0 = a[0], a1 = a[1], a2 = a[2], a3 = a[3];
    for (int i = c; i < n; ++i) {
      double v = col_c[i];
      v -= a0 * x0[i];
      v -= a1 * x1[i];
      v -= a2 * x2[i];
      v -= a3 * x3[i];
      col_c[i] = v;
    }
    return;
  }
  if (w == 3 && all_nonzero) {
    const double *x0 = x[0], *x1 = x[1], *x2 = x[2];
    const double a0 = a[0], a1 = a[1], a2 = a[2];
    for (int i = c; i < n; ++i) {
      double v = col_c[i];
      v -= a0 * x0[i];
      v -= a1 * x1[i];
      v -= a2 * x2[i];
      col_c[i] = v;
    }
    return;
  }
  if (w == 2 && all_nonzero) {
    const double *x0 = x[0], *x1 = x[1];
    const double a0 = a[0], a1 = a[1];
    for (int i = c; i < n; ++i) {
      double v = col_c[i];
      v -= a0 * x0[i];
      v -= a1 * x1[i];
      col_c[i] = v;
    }
    return;
  }
  for (int q = 0; q < w; ++q) {
    if (a[q] == 0.0) continue;  // structural zeros are common (sparse separator couplings)
    const double* xq = x[q];
    const double aq = a[q];
    for (int i = c; i < n; ++i) col_c[i] -= aq * xq[i];
  }
}

// Eliminates columns [c0, c1) of M, updating only columns [c0, update_end) of the trailing
// lower triangle (rows down to n). Returns the failing column or -1. Columns are factored in
// groups of kGroup; the columns right of a group get the group's updates in one pass.
inline int EliminateColumns(double* M, int n, int ld, int c0, int c1, int update_end, double* ref,
                            double tol) {
  constexpr int kGroup = 4;
  for (int j0 = c0; j0 < c1; j0 += kGroup) {
    const int j1 = std::min(c1, j0 + kGroup);
    const double* x[kGroup];
    for (int j = j0; j < j1; ++j) {
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
      x[j - j0] = col_j;
      // Rank-1 update of the rest of the group only.
      for (int c = j + 1; c < j1; ++c) {
        const double a = col_j[c];
        if (a == 0.0) continue;
        double* col_c = M + static_cast<long>(c) * ld;
        for (int i = c; i < n; ++i) col_c[i] -= a * col_j[i];
      }
    }
    // The group's update of the lower triangle of columns [j1, update_end).
    const int w = j1 - j0;
    for (int c = j1; c < update_end; ++c) {
      double a[kGroup];
      for (int q = 0; q < w; ++q) a[q] = x[q][c];
      UpdateColumn(M + static_cast<long>(c) * ld, c, n, x, a, w);
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
    double* trailing_data = M + static_cast<long>(c1) * ld + c1;
    const double* panel_data = M + static_cast<long>(c0) * ld + c1;
    if (rest >= kBlasMinSize) {
      const std::unique_lock<std::mutex> blas = LockBlas();
      cblas_dsyrk(CblasColMajor, CblasLower, CblasNoTrans, rest, c1 - c0, -1.0, panel_data, ld, 1.0,
                  trailing_data, ld);
      continue;
    }
    Eigen::Map<Eigen::MatrixXd, 0, Stride> trailing(trailing_data, rest, rest, Stride(ld));
    Eigen::Map<const Eigen::MatrixXd, 0, Stride> panel(panel_data, rest, c1 - c0, Stride(ld));
    trailing.selfadjointView<Eigen::Lower>().rankUpdate(panel, -1.0);
  }
  return -1;
}

}  // namespace slamd::core::internal
