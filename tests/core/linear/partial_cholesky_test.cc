#include "core/linear/partial_cholesky.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <limits>
#include <random>
#include <thread>
#include <vector>

namespace slamd::core::internal {
namespace {

Eigen::MatrixXd RandomSpd(int n, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd A(n + 3, n);
  for (int i = 0; i < A.size(); ++i) A.data()[i] = normal(*rng);
  return A.transpose() * A + 0.1 * Eigen::MatrixXd::Identity(n, n);
}

double MaxAbs(const Eigen::MatrixXd& m) { return m.size() == 0 ? 0.0 : m.cwiseAbs().maxCoeff(); }

// Sizes on both sides of the unblocked/blocked switch and of the panel width.
class PartialCholeskyTest : public ::testing::TestWithParam<std::pair<int, int>> {};

TEST_P(PartialCholeskyTest, MatchesDenseFactorAndSchurComplement) {
  const auto [n, k] = GetParam();
  std::mt19937 rng(n * 131 + k);
  const Eigen::MatrixXd H = RandomSpd(n, &rng);
  // Work on a copy with a larger leading dimension and garbage in the upper triangle.
  const int ld = n + 5;
  Eigen::MatrixXd storage = Eigen::MatrixXd::Constant(ld, n, 7.0);
  storage.topRows(n).triangularView<Eigen::Lower>() = H;
  std::vector<double> ref(n);
  for (int i = 0; i < n; ++i) ref[i] = H(i, i);
  const std::vector<double> ref0 = ref;
  ASSERT_EQ(PartialCholeskyLower(storage.data(), n, ld, k, ref.data(), 1e-12), -1);
  const Eigen::MatrixXd M = storage.topRows(n);
  if (k == 0) {  // nothing eliminated: the matrix is unchanged
    EXPECT_EQ(M, storage.topRows(n));
    Eigen::MatrixXd lower = M.triangularView<Eigen::Lower>();
    Eigen::MatrixXd want = H.triangularView<Eigen::Lower>();
    EXPECT_EQ(lower, want);
    return;
  }

  // Reference: H_ff = L Lᵀ, W = H_rf L⁻ᵀ, Schur = H_rr − W Wᵀ.
  const Eigen::MatrixXd Hff = H.topLeftCorner(k, k);
  const Eigen::MatrixXd L = Hff.llt().matrixL();
  Eigen::MatrixXd W(n - k, k);
  if (n > k) {  // (Eigen's triangular solve dislikes an empty right-hand side)
    W = L.triangularView<Eigen::Lower>()
            .solve(H.bottomLeftCorner(n - k, k).transpose())
            .transpose();
  }
  const Eigen::MatrixXd schur = H.bottomRightCorner(n - k, n - k) - W * W.transpose();
  const double tol = 1e-10 * H.cwiseAbs().maxCoeff();
  Eigen::MatrixXd got_L = M.topLeftCorner(k, k).triangularView<Eigen::Lower>();
  EXPECT_LE(MaxAbs(got_L - L), tol);
  EXPECT_LE(MaxAbs(M.bottomLeftCorner(n - k, k) - W), tol);
  Eigen::MatrixXd got_schur = M.bottomRightCorner(n - k, n - k).triangularView<Eigen::Lower>();
  Eigen::MatrixXd want_schur = schur.triangularView<Eigen::Lower>();
  EXPECT_LE(MaxAbs(got_schur - want_schur), tol);
  // The pivot references propagate as ref[t] += ref[j] (L_tj / L_jj)², column by column.
  Eigen::MatrixXd L_full(n, k);
  L_full << L, W;
  std::vector<double> want_ref = ref0;
  for (int j = 0; j < k; ++j) {
    for (int t = j + 1; t < n; ++t) {
      want_ref[t] += want_ref[j] * std::pow(L_full(t, j) / L_full(j, j), 2);
    }
  }
  for (int t = 0; t < n; ++t) EXPECT_NEAR(ref[t], want_ref[t], 1e-9 * want_ref[t]) << t;
  // The upper triangle was never written.
  for (int j = 1; j < n; ++j) EXPECT_EQ(storage(0, j), 7.0);
  // Padding rows untouched.
  EXPECT_EQ(storage(n, 0), 7.0);
}

INSTANTIATE_TEST_SUITE_P(Sizes, PartialCholeskyTest,
                         ::testing::Values(std::pair{1, 1}, std::pair{4, 0}, std::pair{4, 4},
                                           std::pair{7, 3}, std::pair{13, 3}, std::pair{64, 20},
                                           std::pair{65, 1}, std::pair{100, 31}, std::pair{100, 64},
                                           std::pair{130, 97}, std::pair{130, 130},
                                           std::pair{300, 200}));

// The unblocked kernel applies several columns per pass over a target column but keeps each
// entry's update order, so on sparse input (structural zeros, also mixed inside a group of
// columns) it must equal the textbook column-by-column right-looking loop bit for bit.
TEST(PartialCholeskyTest, SparseInputMatchesColumnByColumnLoopExactly) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const auto& [n, k] : {std::pair{23, 10}, std::pair{60, 37}, std::pair{64, 64}}) {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n + 3, n);
    for (int i = 0; i < A.size(); ++i) {
      if (uniform(rng) < 0.15) A.data()[i] = normal(rng);
    }
    const Eigen::MatrixXd H = A.transpose() * A + 0.1 * Eigen::MatrixXd::Identity(n, n);
    ASSERT_GT((H.array() == 0.0).count(), n) << "the test needs structural zeros";
    Eigen::MatrixXd got = H;
    std::vector<double> ref(n);
    for (int i = 0; i < n; ++i) ref[i] = H(i, i);
    ASSERT_EQ(PartialCholeskyLower(got.data(), n, n, k, ref.data(), 1e-12), -1);
    Eigen::MatrixXd want = H;
    for (int j = 0; j < k; ++j) {
      want(j, j) = std::sqrt(want(j, j));
      const double inv = 1.0 / want(j, j);
      for (int i = j + 1; i < n; ++i) want(i, j) *= inv;
      for (int c = j + 1; c < n; ++c) {
        for (int i = c; i < n; ++i) want(i, c) -= want(c, j) * want(i, j);
      }
    }
    for (int c = 0; c < n; ++c) {
      for (int i = c; i < n; ++i) EXPECT_EQ(got(i, c), want(i, c)) << n << ": " << i << "," << c;
    }
  }
}

TEST(PartialCholeskyTest, ReportsTheFirstBadPivot) {
  std::mt19937 rng(2);
  for (int n : {6, 90}) {
    // Column 3 is a copy of column 1: the pivot of 3 vanishes (up to round-off).
    Eigen::MatrixXd A(n + 2, n);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = normal(rng);
    A.col(3) = A.col(1);
    Eigen::MatrixXd H = A.transpose() * A;
    std::vector<double> ref(n);
    for (int i = 0; i < n; ++i) ref[i] = H(i, i);
    EXPECT_EQ(PartialCholeskyLower(H.data(), n, n, n, ref.data(), 1e-12), 3);
  }
  // A NaN pivot and a negative one.
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(3, 3);
  H(1, 1) = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> ref(3, 1.0);
  EXPECT_EQ(PartialCholeskyLower(H.data(), 3, 3, 3, ref.data(), 0.0), 1);
  H = Eigen::MatrixXd::Identity(3, 3);
  H(2, 2) = -1.0;
  EXPECT_EQ(PartialCholeskyLower(H.data(), 3, 3, 3, ref.data(), 0.0), 2);
  // Only the eliminated columns are tested: a bad pivot beyond k is not an error.
  H = Eigen::MatrixXd::Identity(3, 3);
  H(2, 2) = -1.0;
  EXPECT_EQ(PartialCholeskyLower(H.data(), 3, 3, 2, ref.data(), 0.0), -1);
}

// Two threads factoring their own wide matrices at once (as the solver's elimination threads do)
// get exactly what each gets alone. Without the BLAS lock (blas_lock.h), Debian's serial
// OpenBLAS returned wrong trailing blocks for ~1 in 2,500 concurrent dsyrk calls.
TEST(PartialCholeskyTest, ConcurrentCallsGetTheResultsOfCallsAlone) {
  constexpr int kSizes[2] = {160, 224};  // 3 and 5 dsyrk calls of >= 64 columns each
  std::mt19937 rng(5);
  std::vector<double> input[2], alone[2], ref[2];
  for (int t = 0; t < 2; ++t) {
    const int n = kSizes[t];
    const Eigen::MatrixXd H = RandomSpd(n, &rng);
    input[t].assign(H.data(), H.data() + H.size());
    alone[t] = input[t];
    ref[t].assign(n, 0.0);
    for (int i = 0; i < n; ++i) ref[t][i] = H(i, i);
    std::vector<double> r = ref[t];
    ASSERT_EQ(PartialCholeskyLower(alone[t].data(), n, n, n - 32, r.data(), 1e-12), -1);
  }
  std::atomic<int> wrong{0};
  const auto factor_many = [&](int t) {
    const int n = kSizes[t];
    for (int i = 0; i < 4000; ++i) {
      std::vector<double> m = input[t], r = ref[t];
      if (PartialCholeskyLower(m.data(), n, n, n - 32, r.data(), 1e-12) != -1 || m != alone[t]) {
        ++wrong;
      }
    }
  };
  std::thread other(factor_many, 1);
  factor_many(0);
  other.join();
  EXPECT_EQ(wrong.load(), 0) << "of 8000 factorisations";
}

}  // namespace
}  // namespace slamd::core::internal
