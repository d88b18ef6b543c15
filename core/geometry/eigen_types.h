// Fixed-size Eigen aliases used throughout slamd, and angle wrapping.
//
// Everything in core/geometry works on fixed-size types so that no call allocates on the heap.
// Naming: VectorN is N x 1, MatrixN is N x N, MatrixMN is M rows x N columns (Jacobian of an
// M-dimensional output with respect to an N-dimensional input).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

namespace slamd::core {

using Vector1 = Eigen::Matrix<double, 1, 1>;
using Vector2 = Eigen::Vector2d;
using Vector3 = Eigen::Vector3d;
using Vector4 = Eigen::Vector4d;
using Vector6 = Eigen::Matrix<double, 6, 1>;

using Matrix2 = Eigen::Matrix2d;
using Matrix3 = Eigen::Matrix3d;
using Matrix4 = Eigen::Matrix4d;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

using Matrix12 = Eigen::Matrix<double, 1, 2>;
using Matrix13 = Eigen::Matrix<double, 1, 3>;
using Matrix16 = Eigen::Matrix<double, 1, 6>;
using Matrix21 = Eigen::Matrix<double, 2, 1>;
using Matrix23 = Eigen::Matrix<double, 2, 3>;
using Matrix26 = Eigen::Matrix<double, 2, 6>;
using Matrix31 = Eigen::Matrix<double, 3, 1>;
using Matrix32 = Eigen::Matrix<double, 3, 2>;
using Matrix36 = Eigen::Matrix<double, 3, 6>;
using Matrix62 = Eigen::Matrix<double, 6, 2>;
using Matrix63 = Eigen::Matrix<double, 6, 3>;

// Points are plain vectors: their "perturbation" is ordinary addition.
using Point2 = Eigen::Vector2d;
using Point3 = Eigen::Vector3d;

inline constexpr double kPi = std::numbers::pi;

// Wraps an angle (radians) into (-pi, pi]. Exact for inputs already in range (no rounding is
// introduced on the fast path); otherwise uses std::remainder, which is exact for doubles.
inline double WrapAngle(double angle) {
  if (angle > -kPi && angle <= kPi) return angle;
  double r = std::remainder(angle, 2.0 * kPi);  // in [-pi, pi]
  if (r <= -kPi) r += 2.0 * kPi;
  return r;
}

}  // namespace slamd::core
