// Checks a factor's analytic (whitened) Jacobians against central finite differences of its
// whitened error under the solver's own retraction (RetractInPlace), for every key.
#pragma once

#include <gtest/gtest.h>

#include <random>

#include "core/factors/factor.h"
#include "tests/testing/numerical_derivative.h"

namespace slamd::testing {

// The keys the factor tests build their factors on: pose x0 and landmark l0.
inline const core::Key kX = core::MakeKey('x', 0);
inline const core::Key kL = core::MakeKey('l', 0);

inline void ExpectJacobiansMatchNumerical(const core::Factor& factor, const core::Values& values,
                                          double tol = 1e-7) {
  core::LinearizedFactor lf;
  factor.Linearize(values, &lf);
  ASSERT_EQ(lf.rows(), factor.dim());
  ASSERT_EQ(lf.num_keys(), static_cast<int>(factor.keys().size()));
  const Eigen::MatrixXd R = factor.noise_model().sqrt_information();
  const Eigen::VectorXd e0 = factor.Error(values);
  EXPECT_TRUE((Eigen::VectorXd(lf.Rhs()) - R * e0).isZero(1e-9)) << factor.Name() << ": b != R e";
  for (int k = 0; k < lf.num_keys(); ++k) {
    const core::Key key = factor.keys()[k];
    const int slot = values.SlotOf(key);
    const int dim = values.DimAt(slot);
    const Eigen::MatrixXd numerical = NumericalJacobian(
        [&](const Eigen::VectorXd& d) {
          core::Values perturbed = values;
          core::RetractInPlace(&perturbed.MutableVariableAt(slot), d.data());
          return Eigen::VectorXd(R * Eigen::VectorXd(factor.Error(perturbed)));
        },
        Eigen::VectorXd::Zero(dim));
    const Eigen::MatrixXd analytic = lf.Block(k);
    EXPECT_TRUE(analytic.isApprox(numerical, tol) || (analytic - numerical).norm() < tol)
        << factor.Name() << " Jacobian for " << core::KeyToString(key) << "\nanalytic:\n"
        << analytic << "\nnumerical:\n"
        << numerical;
  }
}

// Random values for tests (fixed seeds by the caller).
inline core::Pose2 RandomPose2(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  return core::Pose2(u(rng), u(rng), u(rng));
}
inline core::Pose3 RandomPose3(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  return core::Pose3(core::Rot3::Exp(core::Vector3(u(rng), u(rng), u(rng)) * 0.7),
                     core::Point3(u(rng), u(rng), u(rng)));
}
inline Eigen::MatrixXd RandomSpd(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = u(rng);
  return A * A.transpose() + 0.5 * Eigen::MatrixXd::Identity(n, n);
}

}  // namespace slamd::testing
