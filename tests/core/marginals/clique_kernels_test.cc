#include "core/marginals/clique_kernels.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace slamd::core::internal {
namespace {

// Against Eigen's product (the independent reference), over the block widths (1-6 and their
// sums), row counts around the packet blocking, and leading dimensions larger than the sizes.
TEST(CliqueKernelsTest, NegProductTransposedEqualsEigensProduct) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int nf : {1, 2, 3, 4, 5, 6, 7, 9, 12, 13}) {
    for (int m : {1, 2, 3, 4, 5, 7, 8, 9, 31, 40}) {
      const int lda = m + 3, ldc = m + 5;
      Eigen::MatrixXd A(lda, m), K(nf, m), C = Eigen::MatrixXd::Constant(ldc, nf, 7.0);
      for (double* p = A.data(); p != A.data() + A.size(); ++p) *p = u(rng);
      for (double* p = K.data(); p != K.data() + K.size(); ++p) *p = u(rng);
      NegProductTransposed(A.data(), lda, m, K.data(), nf, C.data(), ldc);
      const Eigen::MatrixXd expected = -A.topRows(m) * K.transpose();
      EXPECT_LT((C.topRows(m) - expected).cwiseAbs().maxCoeff(), 1e-13 * m) << "nf " << nf << " m " << m;
      // Rows beyond m (the padding of the leading dimension) are not written.
      EXPECT_TRUE((C.bottomRows(ldc - m).array() == 7.0).all()) << "nf " << nf << " m " << m;
    }
  }
}

TEST(CliqueKernelsTest, PrefetchHasNoEffect) {
  Clique c;
  const int frontals[] = {4, 7}, frontal_dims[] = {3, 2}, separator[] = {9, 1}, separator_dims[] = {3, 3};
  c.Reset(frontals, frontal_dims, separator, separator_dims);
  auto rsd = c.mutable_conditional();
  for (int j = 0; j < rsd.cols(); ++j) rsd.col(j).setConstant(j);
  const Eigen::MatrixXd before = c.conditional();
  const std::uint64_t generation = c.generation();
  Prefetch(c);  // a hint only: must not crash nor change anything
  EXPECT_EQ(Eigen::MatrixXd(c.conditional()), before);
  EXPECT_EQ(c.generation(), generation);
}

}  // namespace
}  // namespace slamd::core::internal
