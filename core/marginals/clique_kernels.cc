#include "core/marginals/clique_kernels.h"

#include <Eigen/Core>
#include <algorithm>

namespace slamd::core::internal {
namespace {

// C = −A Kᵀ for one block of NB ≤ 6 columns: C (m x NB, column-major, ldc), A (m x m, column-major,
// lda), K (NB x m, column-major, ldk). The bulk of every clique's cost (Σ_SF = −Σ_SS Kᵀ) with few
// columns (nF = 2, 3, 6 ...): Eigen's GEMM packs both operands and blocks for large sizes, which
// at these shapes costs as much as the arithmetic; this streams A's columns once, broadcasting
// K's entries, with 2 x NB packet accumulators in registers (Eigen's packet primitives, so it
// follows the SIMD width Eigen was built for). 1.3-2x Eigen's speed for nF <= 6, never slower.
template <int NB>
void NegProductBlock(const double* A, std::ptrdiff_t lda, int m, const double* K, int ldk, double* C,
                     std::ptrdiff_t ldc) {
  namespace ei = Eigen::internal;
  using Packet = ei::packet_traits<double>::type;
  constexpr int kPacket = ei::packet_traits<double>::size;
  int i = 0;
  for (; i + 2 * kPacket <= m; i += 2 * kPacket) {
    Packet acc0[NB], acc1[NB];
    for (int j = 0; j < NB; ++j) acc0[j] = acc1[j] = ei::pset1<Packet>(0.0);
    const double* a = A + i;
    const double* k = K;
    for (int c = 0; c < m; ++c, a += lda, k += ldk) {
      const Packet a0 = ei::ploadu<Packet>(a), a1 = ei::ploadu<Packet>(a + kPacket);
      for (int j = 0; j < NB; ++j) {
        const Packet b = ei::pset1<Packet>(k[j]);
        acc0[j] = ei::pmadd(a0, b, acc0[j]);
        acc1[j] = ei::pmadd(a1, b, acc1[j]);
      }
    }
    for (int j = 0; j < NB; ++j) {
      ei::pstoreu(C + i + j * ldc, ei::pnegate(acc0[j]));
      ei::pstoreu(C + i + kPacket + j * ldc, ei::pnegate(acc1[j]));
    }
  }
  for (; i < m; ++i) {  // the last rows, one at a time
    double acc[NB] = {};
    const double* a = A + i;
    const double* k = K;
    for (int c = 0; c < m; ++c, a += lda, k += ldk) {
      for (int j = 0; j < NB; ++j) acc[j] += *a * k[j];
    }
    for (int j = 0; j < NB; ++j) C[i + j * ldc] = -acc[j];
  }
}

}  // namespace

// C = −A Kᵀ with C m x nf (ldc), A m x m (lda), K nf x m (leading dimension nf), in blocks of
// six columns (more accumulators than registers would spill).
void NegProductTransposed(const double* A, std::ptrdiff_t lda, int m, const double* K, int nf, double* C,
                          std::ptrdiff_t ldc) {
  for (int j0 = 0; j0 < nf; j0 += 6) {
    const double* k = K + j0;
    double* c = C + j0 * ldc;
    switch (std::min(6, nf - j0)) {
      case 1: NegProductBlock<1>(A, lda, m, k, nf, c, ldc); break;
      case 2: NegProductBlock<2>(A, lda, m, k, nf, c, ldc); break;
      case 3: NegProductBlock<3>(A, lda, m, k, nf, c, ldc); break;
      case 4: NegProductBlock<4>(A, lda, m, k, nf, c, ldc); break;
      case 5: NegProductBlock<5>(A, lda, m, k, nf, c, ldc); break;
      default: NegProductBlock<6>(A, lda, m, k, nf, c, ldc); break;
    }
  }
}

// Asks for the clique's [R S] to be brought into the caches (it is read soon).
void Prefetch(const Clique& c) {
  const char* p = reinterpret_cast<const char*>(c.conditional().data());
  const std::size_t bytes = sizeof(double) * c.FrontalDim() * (c.FrontalDim() + c.SeparatorDim());
  for (std::size_t i = 0; i < bytes; i += 64) __builtin_prefetch(p + i, 0, 2);
}

}  // namespace slamd::core::internal
