// Central finite differences, the independent reference for every analytic Jacobian in slamd.
//
// NumericalJacobian: plain vector -> vector functions (factor tests wrap their error functions
// in lambdas). The group helpers apply the slamd perturbation convention: a group argument X is
// perturbed on the RIGHT, X * Exp(d), and a group-valued output Y is compared in the tangent space
// at the unperturbed output, Log(Y0^-1 * Y). Groups need kDim, Exp, Log, Compose and Between
// (Pose2, Rot3, Pose3). Error: O(h^2) truncation + O(eps/h) rounding; h = 1e-6 gives ~1e-9.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <type_traits>
#include <utility>

namespace slamd::testing {

// J(i, j) = (f(x0 + h e_j)_i - f(x0 - h e_j)_i) / (2h).
inline Eigen::MatrixXd NumericalJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x0,
    double h = 1e-6) {
  Eigen::VectorXd x = x0;
  Eigen::MatrixXd J;
  for (Eigen::Index j = 0; j < x0.size(); ++j) {
    x[j] = x0[j] + h;
    const Eigen::VectorXd fp = f(x);
    x[j] = x0[j] - h;
    const Eigen::VectorXd fm = f(x);
    x[j] = x0[j];
    if (j == 0) J.resize(fp.size(), x0.size());
    J.col(j) = (fp - fm) / (2.0 * h);
  }
  return J;
}

// Largest absolute element difference; +infinity when the shapes differ. A plain scalar loop on
// purpose: GCC 12 raises false -Warray-bounds errors on vectorised reductions over small
// dynamic-size matrices built from fixed-size ones.
inline double MaxAbsDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return std::numeric_limits<double>::infinity();
  double m = 0.0;
  for (Eigen::Index j = 0; j < a.cols(); ++j) {
    for (Eigen::Index i = 0; i < a.rows(); ++i) {
      const double d = std::abs(a(i, j) - b(i, j));
      if (!(d <= m)) m = d;  // also propagates NaN
    }
  }
  return m;
}

// MaxAbsDiff scaled by max(1, largest |expected| element): an absolute tolerance for small
// entries, a relative one for large entries.
inline double MaxRelDiff(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected) {
  double scale = 1.0;
  for (Eigen::Index j = 0; j < expected.cols(); ++j) {
    for (Eigen::Index i = 0; i < expected.rows(); ++i) {
      scale = std::max(scale, std::abs(expected(i, j)));
    }
  }
  return MaxAbsDiff(actual, expected) / scale;
}

// X * Exp(d).
template <class G>
G RetractRight(const G& x, const Eigen::VectorXd& d) {
  return x.Compose(G::Exp(Eigen::Matrix<double, G::kDim, 1>(d)));
}

// Log(a^-1 * b): the tangent of b at a under the right-perturbation convention.
template <class G>
Eigen::VectorXd LocalRight(const G& a, const G& b) {
  return Eigen::VectorXd(G::Log(a.Between(b)));
}

namespace internal {
template <class T>
inline constexpr bool kIsEigen = std::is_base_of_v<Eigen::EigenBase<T>, T>;

// Wraps f so its output is a vector: Eigen outputs pass through, group outputs become
// LocalRight(f(x0), f(.)).
template <class Out, class Y>
Eigen::VectorXd OutputTangent(const Out& y0, const Y& y) {
  if constexpr (kIsEigen<Out>) {
    (void)y0;
    return Eigen::VectorXd(y);
  } else {
    return LocalRight(y0, y);
  }
}
}  // namespace internal

// d out(f(X * Exp(d))) / dd at d = 0, where f takes a group element and returns either an Eigen
// vector or a group element (then compared via Log(f(X)^-1 f(.))).
template <class G, class F>
Eigen::MatrixXd NumericalJacobianRight(F&& f, const G& x0, double h = 1e-6) {
  using Out = std::decay_t<std::invoke_result_t<F&, const G&>>;
  const Out y0 = f(x0);
  return NumericalJacobian(
      [&](const Eigen::VectorXd& d) {
        const Out y = f(RetractRight(x0, d));
        return internal::OutputTangent(y0, y);
      },
      Eigen::VectorXd::Zero(G::kDim), h);
}

// d out(f(x0 + d)) / dd at d = 0 for a vector input and an Eigen or group output.
template <class F>
Eigen::MatrixXd NumericalJacobianVector(F&& f, const Eigen::VectorXd& x0, double h = 1e-6) {
  using Out = std::decay_t<std::invoke_result_t<F&, const Eigen::VectorXd&>>;
  const Out y0 = f(x0);
  return NumericalJacobian(
      [&](const Eigen::VectorXd& x) {
        const Out y = f(x);
        return internal::OutputTangent(y0, y);
      },
      x0, h);
}

}  // namespace slamd::testing
