// Per-clique kernels of BayesTreeMarginals (marginals.h): a cache prefetch and the product that
// dominates a clique's marginal. Internal to core/marginals.
#pragma once

#include <cstddef>

#include "core/inference/clique.h"

namespace slamd::core::internal {

// Asks the CPU to bring the clique's [R S] into the caches (no effect on results).
void Prefetch(const Clique& c);

// C = −A Kᵀ, all column-major: C is m x nf (leading dimension ldc), A is m x m (lda), K is nf x m
// (leading dimension nf). A and C must not overlap. For Σ_SF = −Σ_SS Kᵀ with few columns
// (nf = 2, 3, 6 ...): it streams A once per six columns of C with register accumulators, where
// Eigen's GEMM packs both operands (as costly as the arithmetic at these shapes): 1.3-2x faster
// for nf <= 6, never slower (measured at nf = 2..30, m = 10..120). Summation order differs from
// Eigen's: results agree to round-off, and are identical from call to call.
void NegProductTransposed(const double* A, std::ptrdiff_t lda, int m, const double* K, int nf, double* C,
                          std::ptrdiff_t ldc);

}  // namespace slamd::core::internal
