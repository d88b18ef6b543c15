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

// The clique's rows of d_p = d − R p (p = *at; d itself when at is null) into rhs[0, nf), with
// x[0, FrontalDim() + SeparatorDim()) as Gather's scratch.
void RightHandSide(const Clique& c, std::span<const int> var_offsets, const Eigen::VectorXd* at,
                   double* x, double* rhs) {
  const int nf = c.FrontalDim();
  const int n = nf + c.SeparatorDim();
  Eigen::Map<Eigen::VectorXd> out(rhs, nf);
  out = c.d();
  if (at == nullptr) return;
  Gather(c, var_offsets, *at, x);
  out.noalias() -= c.conditional().leftCols(n) * Eigen::Map<const Eigen::VectorXd>(x, n);
}

}  // namespace

void TreeGradient(const TopDownCliques& cliques, std::span<const int> var_offsets,
                  const Eigen::VectorXd* at, Eigen::VectorXd* g, std::vector<double>* scratch) {
  g->setZero(var_offsets.back());
  for (int id : cliques.order) {
    const Clique& c = cliques.tree.clique(id);
    const int nf = c.FrontalDim();
    const int n = nf + c.SeparatorDim();
    scratch->resize(2 * n + nf);
    Eigen::Map<Eigen::VectorXd> out(scratch->data(), n);
    double* rhs = scratch->data() + 2 * n;
    RightHandSide(c, var_offsets, at, scratch->data() + n, rhs);
    // [R S]ᵀ d_p: the clique's rows of R δ = d add this to the gradient of its variables.
    out.noalias() =
        c.conditional().leftCols(n).transpose() * Eigen::Map<const Eigen::VectorXd>(rhs, nf);
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

TreeModelPair ModelTermsOfPair(const TopDownCliques& cliques, std::span<const int> var_offsets,
                               const Eigen::VectorXd* at, const Eigen::VectorXd& a,
                               const Eigen::VectorXd& b, std::vector<double>* scratch) {
  TreeModelPair terms;
  for (int id : cliques.order) {
    const Clique& c = cliques.tree.clique(id);
    const int nf = c.FrontalDim();
    const int n = nf + c.SeparatorDim();
    scratch->resize(2 * n + 3 * nf);
    Eigen::Map<Eigen::MatrixXd> x(scratch->data(), n, 2);  // [a b] at the clique's variables
    Eigen::Map<Eigen::MatrixXd> r(scratch->data() + 2 * n, nf, 2);
    Eigen::Map<Eigen::VectorXd> rhs(scratch->data() + 2 * n + 2 * nf, nf);
    RightHandSide(c, var_offsets, at, x.col(0).data(), rhs.data());
    Gather(c, var_offsets, a, x.col(0).data());
    Gather(c, var_offsets, b, x.col(1).data());
    r.noalias() = c.conditional().leftCols(n) * x;
    terms.aa += r.col(0).squaredNorm();
    terms.ab += r.col(0).dot(r.col(1));
    terms.bb += r.col(1).squaredNorm();
    terms.da += rhs.dot(r.col(0));
    terms.db += rhs.dot(r.col(1));
  }
  return terms;
}

DoglegWeights DoglegPoint(const Eigen::VectorXd& gauss_newton, const Eigen::VectorXd& cauchy,
                          double radius, Eigen::VectorXd* step) {
  const double gn_norm = gauss_newton.norm();
  if (gn_norm <= radius) {
    *step = gauss_newton;
    return {.on_gauss_newton = 1.0};
  }
  const double cauchy_norm = cauchy.norm();
  if (cauchy_norm >= radius) {
    *step = (radius / cauchy_norm) * cauchy;
    return {.on_cauchy = radius / cauchy_norm};
  }
  // |c + τ (n − c)| = radius for τ in [0, 1]: a τ² + 2 b τ + (|c|² − radius²) = 0.
  const Eigen::VectorXd leg = gauss_newton - cauchy;
  const double a = leg.squaredNorm();
  const double b = cauchy.dot(leg);
  const double c = cauchy_norm * cauchy_norm - radius * radius;  // < 0
  const double tau = (-b + std::sqrt(b * b - a * c)) / a;
  *step = cauchy + tau * leg;
  return {.on_gauss_newton = tau, .on_cauchy = 1.0 - tau};
}

}  // namespace slamd::core
