#include "core/isam/dogleg.h"

#include <cmath>

namespace slamd::core {
namespace {

// Gathers the clique's frontal and separator entries of v into x[0, FrontalDim() +
// SeparatorDim()) (frontals first, in R's row order, then the separator in S's column order).
void Gather(const Clique& c, std::span<const int> var_offsets, const Eigen::VectorXd& v,
            double* x) {
  const int nf = c.FrontalDim();
  for (int k = 0; k < c.num_frontals(); ++k) {
    const double* src = v.data() + var_offsets[c.frontal(k)];
    for (int j = 0, dim = c.frontal_dim(k); j < dim; ++j) x[c.frontal_offset(k) + j] = src[j];
  }
  for (int k = 0; k < c.num_separator(); ++k) {
    const double* src = v.data() + var_offsets[c.separator()[k]];
    for (int j = 0, dim = c.separator_dim(k); j < dim; ++j) {
      x[nf + c.separator_offset(k) + j] = src[j];
    }
  }
}

}  // namespace

void TreeGradient(const TopDownCliques& cliques, std::span<const int> var_offsets,
                  Eigen::VectorXd* g, std::vector<double>* scratch) {
  g->setZero(var_offsets.back());
  for (int id : cliques.order) {
    const Clique& c = cliques.tree.clique(id);
    const int nf = c.FrontalDim();
    scratch->resize(nf + c.SeparatorDim());
    Eigen::Map<Eigen::VectorXd> out(scratch->data(), nf + c.SeparatorDim());
    // [R S]ᵀ d: the clique's rows of R δ = d add this to the gradient of its variables.
    out.noalias() = c.conditional().leftCols(nf + c.SeparatorDim()).transpose() * c.d();
    for (int k = 0; k < c.num_frontals(); ++k) {
      double* dst = g->data() + var_offsets[c.frontal(k)];
      for (int j = 0, dim = c.frontal_dim(k); j < dim; ++j) dst[j] += out[c.frontal_offset(k) + j];
    }
    for (int k = 0; k < c.num_separator(); ++k) {
      double* dst = g->data() + var_offsets[c.separator()[k]];
      for (int j = 0, dim = c.separator_dim(k); j < dim; ++j) {
        dst[j] += out[nf + c.separator_offset(k) + j];
      }
    }
  }
}

TreeModelTerms ModelTerms(const TopDownCliques& cliques, std::span<const int> var_offsets,
                          const Eigen::VectorXd& v, std::vector<double>* scratch) {
  TreeModelTerms terms;
  for (int id : cliques.order) {
    const Clique& c = cliques.tree.clique(id);
    const int nf = c.FrontalDim();
    const int n = nf + c.SeparatorDim();
    scratch->resize(n + nf);
    Gather(c, var_offsets, v, scratch->data());
    Eigen::Map<Eigen::VectorXd> rv(scratch->data() + n, nf);
    rv.noalias() =
        c.conditional().leftCols(n) * Eigen::Map<const Eigen::VectorXd>(scratch->data(), n);
    terms.quadratic += rv.squaredNorm();
    terms.linear += c.d().dot(rv);
  }
  return terms;
}

void DoglegPoint(const Eigen::VectorXd& gauss_newton, const Eigen::VectorXd& cauchy, double radius,
                 Eigen::VectorXd* step) {
  const double gn_norm = gauss_newton.norm();
  if (gn_norm <= radius) {
    *step = gauss_newton;
    return;
  }
  const double cauchy_norm = cauchy.norm();
  if (cauchy_norm >= radius) {
    *step = (radius / cauchy_norm) * cauchy;
    return;
  }
  // |c + τ (n − c)| = radius for τ in [0, 1]: a τ² + 2 b τ + (|c|² − radius²) = 0.
  const Eigen::VectorXd leg = gauss_newton - cauchy;
  const double a = leg.squaredNorm();
  const double b = cauchy.dot(leg);
  const double c = cauchy_norm * cauchy_norm - radius * radius;  // < 0
  const double tau = (-b + std::sqrt(b * b - a * c)) / a;
  *step = cauchy + tau * leg;
}

}  // namespace slamd::core
