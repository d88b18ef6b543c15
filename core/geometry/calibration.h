// Camera calibrations as parameter vectors: Cal3_S2 (pinhole), Cal3DS2 (pinhole with radial-
// tangential distortion) and Cal3Bundler (one focal length and two radial terms, the BAL files'
// camera). Each is a plain vector of parameters; as a variable of the optimiser it moves by
// addition (Retract(d) = p + d), so its tangent order is its parameter order.
//
// Conventions (units: pixels for focal lengths, skew and principal point; the distortion terms are
// dimensionless, applied to normalised image coordinates):
//   Cal3_S2:     (fx, fy, s, u0, v0),                  K = [[fx, s, u0], [0, fy, v0], [0, 0, 1]]
//   Cal3DS2:     (fx, fy, s, u0, v0, k1, k2, p1, p2),  OpenCV's k1, k2, p1, p2 on top of K
//   Cal3Bundler: (f, k1, k2),                          r(p) = 1 + k1|p|² + k2|p|⁴ (BAL, Bundler)
// Small value types: cheap to copy, never allocate.
#pragma once

#include <variant>

#include "core/geometry/eigen_types.h"

namespace slamd::core {

namespace internal {

// A calibration of N parameters that moves by addition. Tag makes each model its own type.
template <typename Tag, int N>
class VectorCalibration {
 public:
  static constexpr int kDim = N;
  using Vector = Eigen::Matrix<double, N, 1>;

  VectorCalibration() : p_(Vector::Zero()) {}
  explicit VectorCalibration(const Vector& p) : p_(p) {}

  const Vector& vector() const { return p_; }
  Tag Retract(const Vector& d) const { return Tag(Vector(p_ + d)); }
  Vector LocalCoordinates(const Tag& q) const { return q.vector() - p_; }

 protected:
  Vector p_;
};

}  // namespace internal

class Cal3_S2 : public internal::VectorCalibration<Cal3_S2, 5> {
 public:
  using VectorCalibration::VectorCalibration;
  Cal3_S2(double fx, double fy, double s, double u0, double v0)
      : VectorCalibration((Vector() << fx, fy, s, u0, v0).finished()) {}

  double fx() const { return p_[0]; }
  double fy() const { return p_[1]; }
  double skew() const { return p_[2]; }
  double u0() const { return p_[3]; }
  double v0() const { return p_[4]; }
  // The 3x3 upper-triangular intrinsic matrix.
  Matrix3 K() const {
    Matrix3 k;
    k << fx(), skew(), u0(), 0.0, fy(), v0(), 0.0, 0.0, 1.0;
    return k;
  }
};

class Cal3DS2 : public internal::VectorCalibration<Cal3DS2, 9> {
 public:
  using VectorCalibration::VectorCalibration;
  Cal3DS2(const Cal3_S2& pinhole, double k1, double k2, double p1, double p2) {
    p_ << pinhole.vector(), k1, k2, p1, p2;
  }

  Cal3_S2 pinhole() const { return Cal3_S2(Cal3_S2::Vector(p_.head<5>())); }
  double k1() const { return p_[5]; }
  double k2() const { return p_[6]; }
  double p1() const { return p_[7]; }
  double p2() const { return p_[8]; }
};

class Cal3Bundler : public internal::VectorCalibration<Cal3Bundler, 3> {
 public:
  using VectorCalibration::VectorCalibration;
  Cal3Bundler(double f, double k1, double k2) : VectorCalibration(Vector(f, k1, k2)) {}

  double f() const { return p_[0]; }
  double k1() const { return p_[1]; }
  double k2() const { return p_[2]; }
};

// The monocular calibration models (a reconstruction's cameras, a robot's camera).
using Calibration = std::variant<Cal3_S2, Cal3DS2, Cal3Bundler>;

}  // namespace slamd::core
