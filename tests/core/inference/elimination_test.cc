#include "core/inference/elimination.h"

#include <gtest/gtest.h>

#ifdef __GLIBC__
#include <malloc.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <tuple>

#include "core/inference/consistency_check.h"
#include "tests/core/inference/random_linear_system.h"
#include "tests/testing/glibc_malloc.h"

namespace slamd::core {
namespace {

using testing::EliminateAll;
using testing::MakeOrder;
using testing::MakeRandomSystem;
using testing::NaturalOrder;
using testing::OrderKind;
using testing::RandomLinearSystem;
using testing::Solve;

// The tree's conditionals stacked into one dense upper-triangular R (and d) in the effective
// elimination order (frontals of the cliques in creation order); perm[i] is the original scalar
// index of row/column i.
void DenseConditionals(const BayesTree& tree, const EliminationResult& result,
                       const RandomLinearSystem& s, Eigen::MatrixXd* R, Eigen::VectorXd* d,
                       std::vector<int>* perm) {
  const std::vector<int> orig = s.Offsets();
  std::map<int, int> eff;  // variable -> scalar offset in effective order
  int n = 0;
  perm->clear();
  for (int id : result.cliques) {
    for (int v : tree.clique(id).frontals()) {
      eff[v] = n;
      for (int c = 0; c < s.dims[v]; ++c) perm->push_back(orig[v] + c);
      n += s.dims[v];
    }
  }
  R->setZero(n, n);
  d->setZero(n);
  for (int id : result.cliques) {
    const Clique& c = tree.clique(id);
    const int row = eff[c.frontal(0)];
    R->block(row, row, c.FrontalDim(), c.FrontalDim()) = c.R();
    for (int k = 0; k < c.num_separator(); ++k) {
      R->block(row, eff[c.separator()[k]], c.FrontalDim(), c.separator_dim(k)) =
          c.S().middleCols(c.separator_offset(k), c.separator_dim(k));
    }
    d->segment(row, c.FrontalDim()) = c.d();
  }
}

// Clique rules: one per variable, fundamental supernodes, relaxed supernodes (the default).
enum class Supernodes { kNone, kFundamental, kRelaxed };

EliminationParams WithSupernodes(Supernodes rule) {
  EliminationParams params;
  params.merge_supernodes = rule != Supernodes::kNone;
  if (rule == Supernodes::kFundamental) params.relaxed_new_variables = 0;
  return params;
}

class FullEliminationTest
    : public ::testing::TestWithParam<std::tuple<OrderKind, unsigned, Supernodes, bool>> {};

TEST_P(FullEliminationTest, MatchesDenseSolveAndHessian) {
  const auto [kind, seed, rule, priors_on_all] = GetParam();
  const bool merge = rule != Supernodes::kNone;
  const RandomLinearSystem s = MakeRandomSystem(30, 25, priors_on_all, seed);
  const std::vector<int> order = MakeOrder(s, kind, seed);
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &tree, &result, WithSupernodes(rule)));
  ASSERT_TRUE(CheckConsistency(tree).ok()) << CheckConsistency(tree).ToString();
  EXPECT_EQ(static_cast<int>(result.cliques.size()), tree.NumCliques());
  if (!merge) {
    EXPECT_EQ(tree.NumCliques(), s.NumVars());
  }
  if (rule == Supernodes::kRelaxed) {  // never more cliques than fundamental (fewer in 23 of 24)
    BayesTree fundamental;
    EliminationResult r;
    ASSERT_NO_FATAL_FAILURE(
        EliminateAll(s, order, &fundamental, &r, WithSupernodes(Supernodes::kFundamental)));
    EXPECT_LE(tree.NumCliques(), fundamental.NumCliques());
  }

  // Back-substitution equals the dense solve of AᵀA x = −Aᵀb.
  const Eigen::VectorXd x_ref = s.DenseSolve();
  const Eigen::VectorXd x = Solve(tree, s);
  EXPECT_LT((x - x_ref).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, x_ref.cwiseAbs().maxCoeff()));

  // RᵀR = P AᵀA Pᵀ in the effective order, R upper-triangular, and R x = d.
  Eigen::MatrixXd R;
  Eigen::VectorXd d;
  std::vector<int> perm;
  DenseConditionals(tree, result, s, &R, &d, &perm);
  ASSERT_EQ(static_cast<int>(perm.size()), s.Dim());
  EXPECT_EQ(R.triangularView<Eigen::StrictlyLower>().toDenseMatrix().cwiseAbs().maxCoeff(), 0.0);
  const Eigen::MatrixXd H = s.Hessian();
  Eigen::MatrixXd H_perm(s.Dim(), s.Dim());
  Eigen::VectorXd x_perm(s.Dim());
  for (int i = 0; i < s.Dim(); ++i) {
    x_perm(i) = x_ref(perm[i]);
    for (int j = 0; j < s.Dim(); ++j) H_perm(i, j) = H(perm[i], perm[j]);
  }
  EXPECT_LT((R.transpose() * R - H_perm).cwiseAbs().maxCoeff(), 1e-9 * H.cwiseAbs().maxCoeff());
  EXPECT_LT((R * x_perm - d).cwiseAbs().maxCoeff(), 1e-9 * std::max(1.0, d.cwiseAbs().maxCoeff()));

  // The effective order is a valid reordering of the requested one: each clique's frontals keep
  // their relative order.
  std::vector<int> position(s.NumVars());
  for (int p = 0; p < s.NumVars(); ++p) position[order[p]] = p;
  for (int id : result.cliques) {
    const auto f = tree.clique(id).frontals();
    for (size_t k = 1; k < f.size(); ++k) EXPECT_LT(position[f[k - 1]], position[f[k]]);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Orders, FullEliminationTest,
    ::testing::Combine(::testing::Values(OrderKind::kNatural, OrderKind::kColamd,
                                         OrderKind::kReversed, OrderKind::kRandom),
                       ::testing::Values(1u, 2u, 3u),
                       ::testing::Values(Supernodes::kNone, Supernodes::kFundamental,
                                         Supernodes::kRelaxed),
                       ::testing::Bool()));

TEST(EliminationTest, HessianFactorsGiveTheSameSolution) {
  const RandomLinearSystem s = MakeRandomSystem(20, 15, false, 7);
  // Half of the factors as Jacobians, the other half in information form.
  std::vector<const JacobianFactor*> jacobians;
  std::vector<HessianFactor> hessian_storage;
  for (size_t f = 0; f < s.factors.size(); ++f) {
    if (f % 2 == 0) {
      jacobians.push_back(&s.factors[f]);
    } else {
      hessian_storage.push_back(HessianFactor::FromJacobian(s.factors[f]));
    }
  }
  std::vector<const HessianFactor*> hessians;
  for (const HessianFactor& h : hessian_storage) hessians.push_back(&h);
  const auto order = ColamdOrdering(s.NumVars(), s.Incidence()).value();
  BayesTree tree;
  EliminationResult result;
  const Status status =
      Eliminate({.var_dims = s.dims, .factors = jacobians, .hessians = hessians, .ordering = order},
                &tree, &result);
  ASSERT_TRUE(status.ok()) << status.ToString();
  ASSERT_TRUE(CheckConsistency(tree).ok());
  ASSERT_EQ(result.hessian_cliques.size(), hessians.size());
  for (size_t h = 0; h < hessians.size(); ++h) {
    // The absorbing clique holds the factor's first-eliminated variable as a frontal.
    const Clique& c = tree.clique(result.hessian_cliques[h]);
    int first = -1;
    for (int v : hessians[h]->vars()) {
      if (first < 0 ||
          std::find(order.begin(), order.end(), v) < std::find(order.begin(), order.end(), first)) {
        first = v;
      }
    }
    EXPECT_EQ(tree.CliqueOf(first), result.hessian_cliques[h]);
    EXPECT_GE(c.num_frontals(), 1);
  }
  const Eigen::VectorXd x_ref = s.DenseSolve();
  EXPECT_LT((Solve(tree, s) - x_ref).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(EliminationTest, RootCachedFactorIsTheMinimumError) {
  const RandomLinearSystem s = MakeRandomSystem(12, 10, true, 3);
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, NaturalOrder(s.NumVars()), &tree, &result));
  const Eigen::VectorXd x = s.DenseSolve();
  double error = 0.0;
  for (const JacobianFactor& f : s.factors) error += f.Error(s.Offsets(), x);
  // Each root's cached factor is a constant: the minimum of its component's error.
  double sum = 0.0;
  for (int root : tree.roots()) {
    const HessianFactor& cached = tree.clique(root).cached_factor();
    ASSERT_EQ(cached.num_vars(), 0);
    sum += cached.column(0)[0];
  }
  EXPECT_NEAR(sum, error, 1e-9 * std::max(1.0, error));
}

TEST(EliminationTest, DisconnectedComponentsGiveSeveralRoots) {
  RandomLinearSystem s;
  s.dims = {3, 3, 2, 2};
  std::mt19937 rng(5);
  testing::AddFactor(&s, {0}, 3, &rng);
  testing::AddFactor(&s, {0, 1}, 3, &rng);
  testing::AddFactor(&s, {2}, 2, &rng);
  testing::AddFactor(&s, {3, 2}, 2, &rng);
  BayesTree tree;
  EliminationResult result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, {0, 2, 1, 3}, &tree, &result));
  EXPECT_EQ(tree.roots().size(), 2u);
  ASSERT_TRUE(CheckConsistency(tree).ok());
  EXPECT_LT((Solve(tree, s) - s.DenseSolve()).cwiseAbs().maxCoeff(), 1e-9);
}

// Elimination leaves a reused clique's storage unzeroed (Clique::ResetForElimination), so it
// must write every entry: after a tree's cliques are filled with NaN and freed, eliminating into
// the same slots gives exactly what a fresh tree gets, R's strictly lower part zero.
TEST(EliminationTest, ReusedCliqueStorageIsOverwrittenCompletely) {
  const RandomLinearSystem s = MakeRandomSystem(30, 25, /*priors_on_all=*/false, 4);
  const std::vector<int> order = MakeOrder(s, OrderKind::kColamd, 4);
  BayesTree reused, fresh;
  EliminationResult reused_result, fresh_result;
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &reused, &reused_result));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<int> top_down = reused.TopDownOrder();
  for (int id : top_down) {
    Clique& c = reused.mutable_clique(id);
    c.mutable_conditional().setConstant(nan);
    std::ranges::fill(c.mutable_cached_factor().mutable_packed_info(), nan);
    c.mutable_cached_factor().mutable_reference().setConstant(nan);
  }
  for (auto it = top_down.rbegin(); it != top_down.rend(); ++it) reused.FreeClique(*it);
  ASSERT_EQ(reused.NumCliques(), 0);

  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &reused, &reused_result));
  ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &fresh, &fresh_result));
  ASSERT_EQ(reused_result.cliques.size(), fresh_result.cliques.size());
  int multi_frontal = 0;
  for (size_t k = 0; k < fresh_result.cliques.size(); ++k) {
    const Clique& a = reused.clique(reused_result.cliques[k]);
    const Clique& b = fresh.clique(fresh_result.cliques[k]);
    multi_frontal += a.num_frontals() > 1;
    ASSERT_TRUE(a.conditional().allFinite()) << "clique " << k;
    EXPECT_EQ(a.R().triangularView<Eigen::StrictlyLower>().toDenseMatrix().cwiseAbs().maxCoeff(),
              0.0);
    EXPECT_EQ(a.conditional(), b.conditional()) << "clique " << k;
    EXPECT_EQ(a.cached_factor().Info(), b.cached_factor().Info()) << "clique " << k;
    EXPECT_EQ(a.cached_factor().reference(), b.cached_factor().reference()) << "clique " << k;
  }
  EXPECT_GT(multi_frontal, 0);  // R has a strictly lower part to get wrong
}

// A chain x0 - x1 - ... without any prior: the gauge is free, so the system is indeterminate.
TEST(EliminationTest, IndeterminateSystemNamesTheVariable) {
  RandomLinearSystem s;
  const int n = 6;
  s.dims.assign(n, 3);
  std::mt19937 rng(11);
  for (int i = 0; i + 1 < n; ++i) {
    // "Between" factors A_i = −I, A_{i+1} = I: they see only differences.
    auto f = JacobianFactor::Create(std::vector<int>{i, i + 1},
                                    std::vector<Eigen::MatrixXd>{-Eigen::MatrixXd::Identity(3, 3),
                                                                 Eigen::MatrixXd::Identity(3, 3)},
                                    testing::RandomMatrix(3, 1, &rng));
    ASSERT_TRUE(f.ok());
    s.factors.push_back(f.value());
  }
  for (bool merge : {true, false}) {
    BayesTree tree;
    EliminationResult result;
    const std::vector<const JacobianFactor*> factors = s.Pointers();
    const std::vector<int> order = NaturalOrder(n);
    const Status status = Eliminate({.var_dims = s.dims, .factors = factors, .ordering = order},
                                    &tree, &result, {.merge_supernodes = merge});
    EXPECT_EQ(status.code(), StatusCode::kNumericalFailure);
    // The deficiency shows at the last eliminated variable.
    EXPECT_EQ(result.failed_variable, n - 1);
    EXPECT_NE(status.message().find("variable " + std::to_string(n - 1)), std::string::npos)
        << status.message();
    // The tree is left as it was: empty.
    EXPECT_EQ(tree.NumCliques(), 0);
    EXPECT_TRUE(result.cliques.empty());
    EXPECT_TRUE(CheckConsistency(tree).ok());
  }
}

// A SLAM-like system large enough for the parallel path: a chain of 6-dim poses with loop
// closures to poses up to 40 back, and (optionally) one variable no factor touches.
RandomLinearSystem MakeLoopySystem(int n, bool with_unconstrained) {
  std::mt19937 rng(5);
  RandomLinearSystem s;
  s.dims.assign(n, 6);
  testing::AddFactor(&s, {0}, 6, &rng);
  for (int i = 1; i < n; ++i) {
    testing::AddFactor(&s, {i - 1, i}, 6, &rng);
    if (i % 3 == 0 && i > 40) testing::AddFactor(&s, {i - 10 - static_cast<int>(rng() % 30), i}, 6, &rng);
  }
  if (with_unconstrained) s.dims.push_back(3);
  return s;
}

// Several threads give bitwise the tree of one (same ids, links, conditionals, cached factors),
// and a failure names the same variable and leaves the tree as it was.
TEST(EliminationTest, ThreadsGiveTheSameTreeAndTheSameFailure) {
  for (bool fail : {false, true}) {
    const RandomLinearSystem s = MakeLoopySystem(600, fail);
    auto order = ColamdOrdering(s.NumVars(), s.Incidence());
    ASSERT_TRUE(order.ok());
    const std::vector<const JacobianFactor*> factors = s.Pointers();
    const EliminationProblem problem{.var_dims = s.dims, .factors = factors, .ordering = *order};
    BayesTree trees[2];
    EliminationResult results[2];
    Status status[2];
    for (int t = 0; t < 2; ++t) {
      Eliminator eliminator({}, t + 1);
      status[t] = eliminator.Eliminate(problem, &trees[t], &results[t]);
    }
    ASSERT_EQ(status[0].ok(), !fail) << status[0].ToString();
    EXPECT_EQ(status[1].ToString(), status[0].ToString());
    EXPECT_EQ(results[1].failed_variable, results[0].failed_variable);
    if (fail) {
      EXPECT_EQ(results[0].failed_variable, s.NumVars() - 1);
      for (const BayesTree& tree : trees) {
        EXPECT_EQ(tree.NumCliques(), 0);
        EXPECT_TRUE(CheckConsistency(tree).ok());
      }
      continue;
    }
    EXPECT_EQ(results[0].threads_used, 1);
    EXPECT_EQ(results[1].threads_used, 2) << "too small for the parallel path";
    ASSERT_EQ(results[1].cliques, results[0].cliques);
    EXPECT_TRUE(CheckConsistency(trees[1]).ok());
    for (int id : results[0].cliques) {
      const Clique& a = trees[0].clique(id);
      const Clique& b = trees[1].clique(id);
      ASSERT_TRUE(std::equal(a.frontals().begin(), a.frontals().end(), b.frontals().begin(),
                             b.frontals().end()));
      ASSERT_TRUE(std::equal(a.separator().begin(), a.separator().end(), b.separator().begin(),
                             b.separator().end()));
      EXPECT_EQ(a.parent(), b.parent());
      EXPECT_EQ(a.children(), b.children());
      // Bitwise: == on the matrices, no tolerance.
      EXPECT_TRUE(a.conditional() == b.conditional()) << "clique " << id;
      EXPECT_TRUE(a.cached_factor().Info() == b.cached_factor().Info()) << "clique " << id;
    }
  }
}

#if SLAMD_GLIBC_MALLOC
// Bytes in use in the malloc arenas other than the main one (glibc's malloc_stats, which prints
// them per arena on standard error).
std::size_t InUseOutsideTheMainArena() {
  std::fflush(stderr);
  std::FILE* capture = std::tmpfile();
  const int saved = dup(fileno(stderr));
  dup2(fileno(capture), fileno(stderr));
  malloc_stats();
  std::fflush(stderr);
  dup2(saved, fileno(stderr));
  close(saved);
  std::rewind(capture);
  std::size_t total = 0;
  int arena = -1;
  char line[256];
  while (std::fgets(line, sizeof line, capture)) {
    unsigned long value = 0;
    if (std::sscanf(line, "Arena %d:", &arena) == 1) continue;
    if (std::strncmp(line, "Total", 5) == 0) break;  // the sum over the arenas
    if (arena > 0 && std::sscanf(line, "in use bytes = %lu", &value) == 1) total += value;
  }
  std::fclose(capture);
  return total;
}

// The helpers' cliques are shaped and their workspaces sized by the calling thread, so that
// the helpers allocate nothing: what a helper allocates comes from its own malloc arena, apart
// from the rest of the solver's free blocks (before, the helper's share of the tree was there).
TEST(EliminationTest, HelpersAllocateNothing) {
  const RandomLinearSystem s = MakeLoopySystem(600, /*fail=*/false);
  auto order = ColamdOrdering(s.NumVars(), s.Incidence());
  ASSERT_TRUE(order.ok());
  const std::vector<const JacobianFactor*> factors = s.Pointers();
  const EliminationProblem problem{.var_dims = s.dims, .factors = factors, .ordering = *order};
  Eliminator eliminator({}, 2);  // its workspaces empty
  BayesTree tree;
  EliminationResult result;
  const std::size_t before = InUseOutsideTheMainArena();
  ASSERT_TRUE(eliminator.Eliminate(problem, &tree, &result).ok());
  ASSERT_EQ(result.threads_used, 2);
  EXPECT_EQ(InUseOutsideTheMainArena(), before);
}
#endif

// Round-off accumulates along a chain; with weights varying by 1e5 a pivot test relative to a
// variable's own factors only would miss the deficiency (pivots up to ~1e-11 of them). The
// propagated references catch every case.
TEST(EliminationTest, IndeterminateChainsWithVaryingWeightsAreDetected) {
  std::mt19937 rng(1);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    const int n = 2 + trial % 50;
    RandomLinearSystem s;
    s.dims.assign(n, 3);
    for (int i = 0; i + 1 < n; ++i) {
      const double th = normal(rng);
      Eigen::MatrixXd R(3, 3);
      R << std::cos(th), -std::sin(th), normal(rng), std::sin(th), std::cos(th), normal(rng), 0, 0,
          1;
      const Eigen::MatrixXd W =
          Eigen::MatrixXd::Identity(3, 3) * (1.0 + 100.0 * std::abs(normal(rng)));
      s.factors.push_back(JacobianFactor::Create(std::vector<int>{i, i + 1},
                                                 std::vector<Eigen::MatrixXd>{-W * R, W},
                                                 testing::RandomMatrix(3, 1, &rng))
                              .value());
    }
    std::vector<int> order = NaturalOrder(n);
    if (trial % 2) std::reverse(order.begin(), order.end());
    const std::vector<const JacobianFactor*> factors = s.Pointers();
    BayesTree tree;
    EliminationResult result;
    const Status status =
        Eliminate({.var_dims = s.dims, .factors = factors, .ordering = order}, &tree, &result);
    EXPECT_EQ(status.code(), StatusCode::kNumericalFailure) << "trial " << trial;
  }
}

// The pivot test is relative: a gauge fixed by a prior 1e9 times weaker than the odometry is
// still determined and must not be rejected (only round-off-level pivots are).
TEST(EliminationTest, WeakButDeterminedSystemIsAccepted) {
  RandomLinearSystem s;
  const int n = 30;
  s.dims.assign(n, 3);
  std::mt19937 rng(12);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(3, 3);
  // Information 1e-5 against 1e4 for the odometry.
  auto prior = JacobianFactor::Create(std::vector<int>{0}, std::vector<Eigen::MatrixXd>{3.2e-3 * I},
                                      Eigen::VectorXd::Constant(3, 1e-3));
  ASSERT_TRUE(prior.ok());
  s.factors.push_back(prior.value());
  for (int i = 0; i + 1 < n; ++i) {
    // Odometry with sigma 0.01: whitened blocks of 100 · rotation-ish matrices.
    const Eigen::MatrixXd R =
        Eigen::MatrixXd::Identity(3, 3) + 0.1 * testing::RandomMatrix(3, 3, &rng);
    auto f = JacobianFactor::Create(std::vector<int>{i, i + 1},
                                    std::vector<Eigen::MatrixXd>{-100.0 * R, 100.0 * I},
                                    testing::RandomMatrix(3, 1, &rng));
    ASSERT_TRUE(f.ok());
    s.factors.push_back(f.value());
  }
  for (const auto& order : {NaturalOrder(n), MakeOrder(s, OrderKind::kReversed, 0)}) {
    BayesTree tree;
    EliminationResult result;
    ASSERT_NO_FATAL_FAILURE(EliminateAll(s, order, &tree, &result));
    // The solution is ill-conditioned (condition ~1e10), so check backward stability: the
    // normal-equation residual is at round-off level relative to |AᵀA| |x|.
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
    s.Dense(&A, &b);
    const Eigen::VectorXd x = Solve(tree, s);
    const Eigen::MatrixXd H = A.transpose() * A;
    const double residual = (H * x + A.transpose() * b).norm();
    EXPECT_LT(residual, 1e-12 * H.norm() * x.norm());
  }
}

TEST(EliminationTest, UnconstrainedVariableAndNonFiniteInputFail) {
  RandomLinearSystem s = MakeRandomSystem(5, 3, true, 2);
  s.dims.push_back(2);  // variable 5: no factor at all
  std::vector<int> order = NaturalOrder(6);
  BayesTree tree;
  EliminationResult result;
  std::vector<const JacobianFactor*> factors = s.Pointers();
  Status status =
      Eliminate({.var_dims = s.dims, .factors = factors, .ordering = order}, &tree, &result);
  EXPECT_EQ(status.code(), StatusCode::kNumericalFailure);
  EXPECT_EQ(result.failed_variable, 5);
  EXPECT_NE(status.message().find("variable 5"), std::string::npos) << status.message();

  // A NaN in a right-hand side is reported, not propagated.
  RandomLinearSystem t = MakeRandomSystem(5, 3, true, 2);
  t.factors[2].mutable_b()(0) = std::numeric_limits<double>::quiet_NaN();
  factors = t.Pointers();
  order = NaturalOrder(5);
  status = Eliminate({.var_dims = t.dims, .factors = factors, .ordering = order}, &tree, &result);
  EXPECT_EQ(status.code(), StatusCode::kNumericalFailure) << status.ToString();
  EXPECT_GE(result.failed_variable, 0);
  EXPECT_EQ(tree.NumCliques(), 0);
}

TEST(EliminationTest, InvalidProblemsAreRejectedWithoutChangingTheTree) {
  const RandomLinearSystem s = MakeRandomSystem(6, 4, true, 4);
  const std::vector<const JacobianFactor*> factors = s.Pointers();
  BayesTree tree;
  EliminationResult result;
  Eliminator eliminator;
  auto run = [&](std::span<const int> dims, std::span<const int> order) {
    return eliminator.Eliminate({.var_dims = dims, .factors = factors, .ordering = order}, &tree,
                                &result);
  };
  // Duplicate, out of range, a factor variable missing from the ordering, a wrong dim.
  EXPECT_EQ(run(s.dims, std::vector<int>{0, 1, 2, 3, 4, 4}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(run(s.dims, std::vector<int>{0, 1, 2, 3, 4, 9}).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(run(s.dims, std::vector<int>{0, 1, 2, 3, 4}).code(), StatusCode::kInvalidArgument);
  std::vector<int> wrong_dims = s.dims;
  wrong_dims[3] += 1;
  EXPECT_EQ(run(wrong_dims, NaturalOrder(6)).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(tree.NumCliques(), 0);
  // The eliminator's workspace was reset after every failure: a valid run still works.
  ASSERT_TRUE(run(s.dims, NaturalOrder(6)).ok());
  EXPECT_LT((Solve(tree, s) - s.DenseSolve()).cwiseAbs().maxCoeff(), 1e-9);
  // Variables already in the tree cannot be eliminated again.
  const int cliques = tree.NumCliques();
  EXPECT_EQ(run(s.dims, NaturalOrder(6)).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(tree.NumCliques(), cliques);
  EXPECT_EQ(Eliminator({.relative_pivot_tolerance = -1.0})
                .Eliminate({.var_dims = s.dims, .factors = factors, .ordering = NaturalOrder(6)},
                           &tree, &result)
                .code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace slamd::core
