// Random block least-squares problems for the linear-layer tests, with a dense reference:
// the stacked Jacobian J (original scalar order) gives H = JᵀJ and b = -Jᵀe independently of
// BlockSparseSystem.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <vector>

#include "core/linear/block_sparse_system.h"
#include "core/linear/ordering.h"

namespace slamd::core::testing {

struct RandomFactor {
  std::vector<Eigen::MatrixXd> jacobians;  // m x d_k each, column-major
  Eigen::VectorXd error;                   // m
};

struct RandomBlockProblem {
  std::vector<int> dims;
  FactorIncidence incidence;
  std::vector<RandomFactor> factors;

  int Dim() const {
    int d = 0;
    for (int x : dims) d += x;
    return d;
  }
  std::vector<int> OriginalOffsets() const {
    std::vector<int> off(dims.size());
    for (size_t v = 1; v < dims.size(); ++v) off[v] = off[v - 1] + dims[v - 1];
    return off;
  }
  // Dense reference H = JᵀJ and b = -Jᵀe (original order).
  void DenseNormalEquations(Eigen::MatrixXd* h, Eigen::VectorXd* b) const {
    const std::vector<int> off = OriginalOffsets();
    h->setZero(Dim(), Dim());
    b->setZero(Dim());
    for (int f = 0; f < incidence.NumFactors(); ++f) {
      const RandomFactor& factor = factors[f];
      // The factor's rows of J touch only its variables' columns: their products, block by
      // block (a dense m x Dim row block per factor made this reference quadratic in Dim).
      const int begin = incidence.offsets[f], n = incidence.offsets[f + 1] - begin;
      for (int k = 0; k < n; ++k) {
        const int v = incidence.vars[begin + k];
        b->segment(off[v], dims[v]) -= factor.jacobians[k].transpose() * factor.error;
        for (int l = 0; l < n; ++l) {
          const int w = incidence.vars[begin + l];
          h->block(off[v], off[w], dims[v], dims[w]) +=
              factor.jacobians[k].transpose() * factor.jacobians[l];
        }
      }
    }
  }
  // Assembles all factors into `system` (after SetZero).
  void Assemble(BlockSparseSystem* system) const {
    system->SetZero();
    std::vector<const double*> blocks;
    for (int f = 0; f < incidence.NumFactors(); ++f) {
      blocks.clear();
      for (const Eigen::MatrixXd& jk : factors[f].jacobians) blocks.push_back(jk.data());
      system->AddFactor(f, blocks.data(), factors[f].error.data(),
                        static_cast<int>(factors[f].error.size()));
    }
  }
};

// num_vars variables with dimensions from `dim_choices`; a prior (m = d) on every variable when
// `priors` (makes H positive definite), a chain of between factors, and `extra` random factors of
// arity 1-3 with m in 1..6 (some square m = d ones to exercise the fixed-size kernels).
inline RandomBlockProblem MakeRandomBlockProblem(int num_vars, int extra, bool priors,
                                                 std::mt19937* rng,
                                                 std::vector<int> dim_choices = {1, 2, 3, 6}) {
  RandomBlockProblem p;
  std::uniform_int_distribution<int> pick_dim(0, static_cast<int>(dim_choices.size()) - 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int v = 0; v < num_vars; ++v) p.dims.push_back(dim_choices[pick_dim(*rng)]);
  auto add = [&](const std::vector<int>& vars, int m) {
    RandomFactor factor;
    for (int v : vars) {
      Eigen::MatrixXd jk(m, p.dims[v]);
      for (int i = 0; i < jk.size(); ++i) jk.data()[i] = normal(*rng);
      factor.jacobians.push_back(jk);
    }
    factor.error.resize(m);
    for (int i = 0; i < m; ++i) factor.error[i] = normal(*rng);
    p.incidence.AddFactor(vars);
    p.factors.push_back(std::move(factor));
  };
  if (priors) {
    for (int v = 0; v < num_vars; ++v) add({v}, p.dims[v]);
  }
  for (int v = 0; v + 1 < num_vars; ++v) {
    add({v, v + 1}, p.dims[v] == p.dims[v + 1] ? p.dims[v] : 3);
  }
  std::uniform_int_distribution<int> var(0, num_vars - 1), arity(1, 3), m_dist(1, 6);
  for (int f = 0; f < extra; ++f) {
    std::vector<int> vars;
    const int size = std::min(arity(*rng), num_vars);
    while (static_cast<int>(vars.size()) < size) {
      const int v = var(*rng);
      if (std::find(vars.begin(), vars.end(), v) == vars.end()) vars.push_back(v);
    }
    int m = m_dist(*rng);
    if (f % 3 == 0 && std::all_of(vars.begin(), vars.end(),
                                  [&](int v) { return p.dims[v] == p.dims[vars[0]]; })) {
      m = p.dims[vars[0]];  // square: hits the unrolled kernels
    }
    add(vars, m);
  }
  return p;
}

}  // namespace slamd::core::testing
