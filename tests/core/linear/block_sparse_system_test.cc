#include "core/linear/block_sparse_system.h"

#include <gtest/gtest.h>

#include <numeric>
#include <random>
#include <vector>

#include "core/linear/ordering.h"
#include "tests/core/linear/random_block_problem.h"

namespace slamd::core {
namespace {

using testing::MakeRandomBlockProblem;
using testing::RandomBlockProblem;

std::vector<std::vector<int>> TestOrders(const RandomBlockProblem& p, std::mt19937* rng) {
  const int n = static_cast<int>(p.dims.size());
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  std::vector<int> reversed(identity.rbegin(), identity.rend());
  std::vector<int> shuffled = identity;
  std::shuffle(shuffled.begin(), shuffled.end(), *rng);
  std::vector<std::vector<int>> orders = {identity, reversed, shuffled};
  const auto colamd = ColamdOrdering(n, p.incidence);
  if (colamd.ok()) orders.push_back(*colamd);
  return orders;
}

// Structural checks of the CSC arrays against the contract in the header.
void ExpectWellFormed(const BlockSparseSystem& s) {
  const auto& cp = s.col_ptr();
  const auto& ri = s.row_idx();
  ASSERT_EQ(static_cast<int>(cp.size()), s.Dim() + 1);
  EXPECT_EQ(cp[0], 0);
  EXPECT_EQ(cp.back(), s.NumNonZeros());
  EXPECT_EQ(static_cast<int>(s.values().size()), s.NumNonZeros());
  for (int j = 0; j < s.Dim(); ++j) {
    ASSERT_LT(cp[j], cp[j + 1]) << "column " << j << " has no diagonal";
    EXPECT_EQ(ri[cp[j + 1] - 1], j) << "diagonal must be last in column " << j;
    for (int p = cp[j] + 1; p < cp[j + 1]; ++p) EXPECT_LT(ri[p - 1], ri[p]);
  }
}

TEST(BlockSparseSystemTest, MatchesDenseNormalEquationsForRandomOrders) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 8; ++trial) {
    const RandomBlockProblem p = MakeRandomBlockProblem(5 + 4 * trial, 3 * trial + 4, trial % 2,
                                                        &rng);
    Eigen::MatrixXd h_ref;
    Eigen::VectorXd b_ref;
    p.DenseNormalEquations(&h_ref, &b_ref);
    for (const std::vector<int>& order : TestOrders(p, &rng)) {
      auto system = BlockSparseSystem::Create(p.dims, order, p.incidence);
      ASSERT_TRUE(system.ok()) << system.status().ToString();
      ExpectWellFormed(*system);
      p.Assemble(&*system);
      EXPECT_LT((system->ToDense() - h_ref).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
      EXPECT_LT((system->RhsOriginalOrder() - b_ref).cwiseAbs().maxCoeff(), 1e-12);
      // Assembling twice after SetZero gives the same (no stale values).
      p.Assemble(&*system);
      EXPECT_LT((system->ToDense() - h_ref).cwiseAbs().maxCoeff(), 1e-12);
    }
  }
}

TEST(BlockSparseSystemTest, PatternHoldsExactlyTheCoupledBlocks) {
  std::mt19937 rng(5);
  const RandomBlockProblem p = MakeRandomBlockProblem(12, 6, false, &rng);
  const int n = 12;
  std::vector<std::vector<bool>> coupled(n, std::vector<bool>(n, false));
  for (int v = 0; v < n; ++v) coupled[v][v] = true;
  for (int f = 0; f < p.incidence.NumFactors(); ++f) {
    for (int i = p.incidence.offsets[f]; i < p.incidence.offsets[f + 1]; ++i) {
      for (int j = p.incidence.offsets[f]; j < p.incidence.offsets[f + 1]; ++j) {
        coupled[p.incidence.vars[i]][p.incidence.vars[j]] = true;
      }
    }
  }
  long expected = 0;
  for (int a = 0; a < n; ++a) {
    expected += p.dims[a] * (p.dims[a] + 1) / 2;
    for (int b = a + 1; b < n; ++b) expected += coupled[a][b] ? p.dims[a] * p.dims[b] : 0;
  }
  for (const auto& order : TestOrders(p, &rng)) {
    auto system = BlockSparseSystem::Create(p.dims, order, p.incidence);
    ASSERT_TRUE(system.ok());
    EXPECT_EQ(system->NumNonZeros(), expected);
    // Offsets follow the elimination order.
    int offset = 0;
    for (int v : order) {
      EXPECT_EQ(system->Offset(v), offset);
      offset += p.dims[v];
    }
    EXPECT_EQ(system->Dim(), offset);
  }
}

TEST(BlockSparseSystemTest, DiagonalOperations) {
  std::mt19937 rng(9);
  const RandomBlockProblem p = MakeRandomBlockProblem(10, 8, true, &rng);
  std::vector<int> order(10);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  auto system = BlockSparseSystem::Create(p.dims, order, p.incidence);
  ASSERT_TRUE(system.ok());
  p.Assemble(&*system);
  Eigen::MatrixXd h;
  Eigen::VectorXd b;
  p.DenseNormalEquations(&h, &b);
  EXPECT_LT((system->Diagonal() - h.diagonal()).cwiseAbs().maxCoeff(), 1e-12);

  const std::vector<double> saved = system->values();
  system->AddToDiagonal(0.5);
  Eigen::MatrixXd expected = h;
  expected.diagonal().array() += 0.5;
  EXPECT_LT((system->ToDense() - expected).cwiseAbs().maxCoeff(), 1e-12);

  Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(system->Dim(), 1.0, 2.0);
  system->AddDiagonal(d);
  expected.diagonal() += d;
  EXPECT_LT((system->ToDense() - expected).cwiseAbs().maxCoeff(), 1e-12);

  system->values() = saved;  // LM restore
  EXPECT_LT((system->ToDense() - h).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(BlockSparseSystemTest, ReorderingAndMultiply) {
  std::mt19937 rng(13);
  const RandomBlockProblem p = MakeRandomBlockProblem(15, 20, false, &rng);
  const auto order = ColamdOrdering(15, p.incidence);
  ASSERT_TRUE(order.ok());
  auto system = BlockSparseSystem::Create(p.dims, *order, p.incidence);
  ASSERT_TRUE(system.ok());
  p.Assemble(&*system);
  const Eigen::VectorXd x = Eigen::VectorXd::Random(system->Dim());
  Eigen::VectorXd x_perm, x_back;
  system->FromOriginalOrder(x, &x_perm);
  system->ToOriginalOrder(x_perm, &x_back);
  EXPECT_EQ(x_back, x);
  // Permuted scalar of original scalar OriginalOffset(v) + i is Offset(v) + i.
  for (int v = 0; v < 15; ++v) {
    for (int i = 0; i < p.dims[v]; ++i) {
      EXPECT_EQ(x_perm[system->Offset(v) + i], x[system->OriginalOffset(v) + i]);
    }
  }
  Eigen::VectorXd y_perm, y;
  system->MultiplyPermuted(x_perm, &y_perm);
  system->ToOriginalOrder(y_perm, &y);
  EXPECT_LT((y - system->ToDense() * x).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(BlockSparseSystemTest, UntouchedVariableGetsAZeroDiagonalBlock) {
  FactorIncidence incidence;
  incidence.AddFactor({0, 2});
  auto system = BlockSparseSystem::Create({3, 2, 3}, {2, 1, 0}, incidence);
  ASSERT_TRUE(system.ok());
  ExpectWellFormed(*system);
  EXPECT_EQ(system->NumNonZeros(), 6 + 3 + 6 + 9);
  const Eigen::MatrixXd j0 = Eigen::MatrixXd::Identity(3, 3), j2 = 2 * j0;
  const Eigen::Vector3d e(1, 2, 3);
  const double* blocks[] = {j0.data(), j2.data()};
  system->AddFactor(0, blocks, e.data(), 3);
  const Eigen::MatrixXd h = system->ToDense();
  EXPECT_TRUE(h.block(3, 0, 2, 8).isZero());
  EXPECT_EQ(h(0, 0), 1.0);
  EXPECT_EQ(h(0, 5), 2.0);
  EXPECT_EQ(h(5, 5), 4.0);
  EXPECT_EQ(system->RhsOriginalOrder()[6], -4.0);
  EXPECT_EQ(system->RhsOriginalOrder()[0], -1.0);
}

TEST(BlockSparseSystemTest, EmptySystem) {
  auto system = BlockSparseSystem::Create({}, {}, FactorIncidence{});
  ASSERT_TRUE(system.ok());
  EXPECT_EQ(system->Dim(), 0);
  EXPECT_EQ(system->NumNonZeros(), 0);
}

TEST(BlockSparseSystemTest, RejectsInconsistentInput) {
  FactorIncidence incidence;
  incidence.AddFactor({0, 1});
  EXPECT_EQ(BlockSparseSystem::Create({3, 3}, {0, 0}, incidence).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BlockSparseSystem::Create({3, 3}, {0}, incidence).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BlockSparseSystem::Create({3, 0}, {0, 1}, incidence).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(BlockSparseSystem::Create({3}, {0}, incidence).status().code(),
            StatusCode::kInvalidArgument);  // variable 1 out of range
  FactorIncidence duplicate;
  duplicate.AddFactor({1, 0, 1});
  EXPECT_EQ(BlockSparseSystem::Create({3, 3}, {0, 1}, duplicate).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(BlockSparseSystemTest, CopiesAreIndependent) {
  std::mt19937 rng(21);
  const RandomBlockProblem p = MakeRandomBlockProblem(6, 4, true, &rng);
  std::vector<int> order = {5, 4, 3, 2, 1, 0};
  auto system = BlockSparseSystem::Create(p.dims, order, p.incidence);
  ASSERT_TRUE(system.ok());
  p.Assemble(&*system);
  BlockSparseSystem copy = *system;
  copy.AddToDiagonal(1.0);
  EXPECT_NE(copy.values(), system->values());
  Eigen::MatrixXd h;
  Eigen::VectorXd b;
  p.DenseNormalEquations(&h, &b);
  EXPECT_LT((system->ToDense() - h).cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
}  // namespace slamd::core
