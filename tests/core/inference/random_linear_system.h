// Random sparse linear least-squares systems for the inference tests, with an independent dense
// reference: the stacked Jacobian A and rhs b give H = AᵀA and the solution of AᵀA x = −Aᵀb.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

#include "core/inference/back_substitution.h"
#include "core/inference/bayes_tree.h"
#include "core/inference/elimination.h"
#include "core/inference/jacobian_factor.h"
#include "core/linear/ordering.h"

namespace slamd::core::testing {

struct RandomLinearSystem {
  std::vector<int> dims;
  std::vector<JacobianFactor> factors;

  int NumVars() const { return static_cast<int>(dims.size()); }
  std::vector<int> Offsets() const {
    std::vector<int> off(dims.size() + 1, 0);
    for (size_t v = 0; v < dims.size(); ++v) off[v + 1] = off[v] + dims[v];
    return off;
  }
  int Dim() const { return Offsets().back(); }
  std::vector<const JacobianFactor*> Pointers() const {
    std::vector<const JacobianFactor*> p;
    for (const JacobianFactor& f : factors) p.push_back(&f);
    return p;
  }
  FactorIncidence Incidence() const {
    FactorIncidence inc;
    for (const JacobianFactor& f : factors) inc.AddFactor({f.vars().begin(), f.vars().end()});
    return inc;
  }
  // Dense stacked A (all factor rows, variables in id order) and b.
  void Dense(Eigen::MatrixXd* A, Eigen::VectorXd* b) const {
    const std::vector<int> off = Offsets();
    int rows = 0;
    for (const JacobianFactor& f : factors) rows += f.rows();
    A->setZero(rows, Dim());
    b->setZero(rows);
    int r = 0;
    for (const JacobianFactor& f : factors) {
      for (int k = 0; k < f.num_vars(); ++k) {
        A->block(r, off[f.var(k)], f.rows(), f.dim(k)) = f.A(k);
      }
      b->segment(r, f.rows()) = f.b();
      r += f.rows();
    }
  }
  Eigen::MatrixXd Hessian() const {
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
    Dense(&A, &b);
    return A.transpose() * A;
  }
  // x = −(AᵀA)⁻¹ Aᵀb, in id order.
  Eigen::VectorXd DenseSolve() const {
    Eigen::MatrixXd A;
    Eigen::VectorXd b;
    Dense(&A, &b);
    const Eigen::MatrixXd H = A.transpose() * A;
    return H.ldlt().solve(-A.transpose() * b);
  }
};

inline Eigen::MatrixXd RandomMatrix(int rows, int cols, std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(*rng);
  return m;
}

inline void AddFactor(RandomLinearSystem* s, std::vector<int> vars, int rows, std::mt19937* rng) {
  std::vector<Eigen::MatrixXd> blocks;
  for (int v : vars) blocks.push_back(RandomMatrix(rows, s->dims[v], rng));
  const Eigen::VectorXd b = RandomMatrix(rows, 1, rng);
  auto f = JacobianFactor::Create(vars, blocks, b);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  s->factors.push_back(std::move(f).value());
}

// num_vars variables with dims from {2, 3, 6}. Full rank in one of two ways:
//   * priors_on_all: a square prior on every variable, then `extra` random 1-2-variable factors
//     with 1..6 rows;
//   * otherwise: one prior on variable 0 and a random spanning tree of binary factors whose rows
//     cover the child's dim (full column rank), then the extra factors.
inline RandomLinearSystem MakeRandomSystem(int num_vars, int extra, bool priors_on_all,
                                           unsigned seed) {
  std::mt19937 rng(seed);
  RandomLinearSystem s;
  const int dim_choices[] = {2, 3, 6};
  std::uniform_int_distribution<int> pick(0, 2);
  for (int v = 0; v < num_vars; ++v) s.dims.push_back(dim_choices[pick(rng)]);
  if (priors_on_all) {
    for (int v = 0; v < num_vars; ++v) AddFactor(&s, {v}, s.dims[v], &rng);
  } else {
    AddFactor(&s, {0}, s.dims[0], &rng);
    for (int v = 1; v < num_vars; ++v) {
      // Mostly near neighbours (a chain-like tree, as in SLAM), sometimes far.
      std::uniform_int_distribution<int> far(0, v - 1);
      const int parent = (rng() % 4 == 0) ? far(rng) : v - 1;
      AddFactor(&s, {parent, v}, s.dims[v], &rng);
    }
  }
  std::uniform_int_distribution<int> var(0, num_vars - 1);
  std::uniform_int_distribution<int> rows(1, 6);
  for (int e = 0; e < extra; ++e) {
    const int a = var(rng);
    const int b = var(rng);
    if (a == b || rng() % 5 == 0) {
      AddFactor(&s, {a}, rows(rng), &rng);
    } else {
      AddFactor(&s, {a, b}, rows(rng), &rng);
    }
  }
  return s;
}

// Eliminates all variables of `s` in `ordering` into a fresh tree (asserting success).
inline void EliminateAll(const RandomLinearSystem& s, const std::vector<int>& ordering,
                         BayesTree* tree, EliminationResult* result,
                         const EliminationParams& params = {}) {
  const std::vector<const JacobianFactor*> factors = s.Pointers();
  const EliminationProblem problem{
      .var_dims = s.dims, .factors = factors, .hessians = {}, .ordering = ordering};
  const Status status = Eliminate(problem, tree, result, params);
  ASSERT_TRUE(status.ok()) << status.ToString();
}

inline std::vector<int> NaturalOrder(int n) {
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  return order;
}

// Elimination orders for the tests, and the solution a tree gives by back-substitution.
enum class OrderKind { kNatural, kColamd, kReversed, kRandom };

inline std::vector<int> MakeOrder(const RandomLinearSystem& s, OrderKind kind, unsigned seed) {
  std::vector<int> order = NaturalOrder(s.NumVars());
  switch (kind) {
    case OrderKind::kNatural:
      break;
    case OrderKind::kColamd: {
      auto colamd = ColamdOrdering(s.NumVars(), s.Incidence());
      EXPECT_TRUE(colamd.ok());
      order = colamd.value();
      break;
    }
    case OrderKind::kReversed:
      std::reverse(order.begin(), order.end());
      break;
    case OrderKind::kRandom: {
      std::mt19937 rng(seed + 1000);
      std::shuffle(order.begin(), order.end(), rng);
      break;
    }
  }
  return order;
}

inline Eigen::VectorXd Solve(const BayesTree& tree, const RandomLinearSystem& s) {
  const std::vector<int> offsets = s.Offsets();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(s.Dim());
  BackSubstitute(tree, offsets, &x);
  return x;
}

}  // namespace slamd::core::testing
