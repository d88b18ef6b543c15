// Partial Cholesky factorisation of a dense symmetric matrix: the numeric kernel of clique
// elimination (multifrontal method) and of the dense reduced camera system. Internal to core.
//
// Given symmetric M (n x n, only the LOWER triangle is read and written, column-major with
// leading dimension ld) partitioned as [[M_ff, .], [M_rf, M_rr]] with f = the first `k` rows and
// columns, it computes in place
//     M_ff ← L   (lower, L Lᵀ = M_ff),
//     M_rf ← M_rf L⁻ᵀ,
//     M_rr ← M_rr − M_rf L⁻ᵀ L⁻¹ M_fr   (the Schur complement),
// i.e. k steps of right-looking Cholesky. For the augmented clique matrix [[H, g], [gᵀ, c]] over
// frontals + separator + rhs this yields Rᵀ = L, Sᵀ and −dᵀ in the first k columns and the cached
// factor in the trailing block.
//
// Failure: the pivot p_j (the diagonal entry when column j is reached) must satisfy
// p_j > tol · ref[j] (also false for NaN); the first j that fails is returned and M is left
// partially updated; -1 means success. ref (n entries, >= 0) bounds the magnitude of what was
// summed into each diagonal entry, so round-off in p_j is ~eps · ref[j]: a variable without
// enough constraints has a pivot at round-off level, not exactly 0. ref is updated in place as
// the error bound propagates: after column j, ref[t] += ref[j] · (L_tj / L_jj)² for t > j (how
// much an error in p_j moves entry t's Schur complement). On return ref[k..n) is the reference
// of the trailing (Schur complement) scalars.
//
// Cost: k²(n − k/3)-ish flops; small matrices use a plain unblocked loop (no Eigen call
// overhead), larger ones a blocked panel + rank-update scheme, whose wide rank updates go to the
// BLAS (dsyrk: OpenBLAS chooses AVX2/AVX-512 kernels at run time, where this build targets the
// x86-64 baseline), one call at a time in the process (blas_lock.h: Debian's serial OpenBLAS is
// not safe for concurrent calls). Rate: `build/tests/core_kernels_bench
// --benchmark_filter=PartialCholesky`.
#pragma once

namespace slamd::core::internal {

int PartialCholeskyLower(double* M, int n, int ld, int k, double* ref, double tol);

}  // namespace slamd::core::internal
