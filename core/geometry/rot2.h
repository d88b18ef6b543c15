// Rot2: a planar rotation (SO(2)), stored as (cos theta, sin theta).
//
// Storing cos/sin instead of the angle makes Compose and Rotate pure multiply-adds (no
// trigonometry); the angle is computed on demand with atan2 and always lies in (-pi, pi].
//
// Jacobians follow the slamd convention: with respect to a RIGHT perturbation R * Exp(d) for the
// rotation (d is a scalar angle in radians) and plain addition for points. Jacobian out-params
// are raw pointers; nullptr means "not wanted" and costs nothing.
// Rot2 is a small value type: cheap to copy, thread-compatible, never allocates.
#pragma once

#include "core/geometry/eigen_types.h"

namespace slamd::core {

class Rot2 {
 public:
  // Identity rotation.
  Rot2() = default;

  // Rotation by `theta` radians (any real value; wrapped implicitly).
  static Rot2 FromAngle(double theta) { return Rot2(std::cos(theta), std::sin(theta)); }

  // Rotation whose (cos, sin) is the direction of (c, s); (c, s) is normalised to unit length
  // (kept as given when unit length to rounding). (0, 0) has no direction and yields the identity.
  static Rot2 FromCosSin(double c, double s);

  // Angle in (-pi, pi].
  double theta() const;
  double c() const { return c_; }
  double s() const { return s_; }

  // [[c, -s], [s, c]].
  Matrix2 matrix() const;

  // this * b. The result is renormalised with one cheap Newton step so that long chains of
  // compositions do not drift off the unit circle.
  Rot2 Compose(const Rot2& b) const {
    return Renormalized(c_ * b.c_ - s_ * b.s_, s_ * b.c_ + c_ * b.s_);
  }
  Rot2 operator*(const Rot2& b) const { return Compose(b); }
  Rot2 Inverse() const { return Rot2(c_, -s_); }
  // this^-1 * b.
  Rot2 Between(const Rot2& b) const {
    return Renormalized(c_ * b.c_ + s_ * b.s_, c_ * b.s_ - s_ * b.c_);
  }

  // R * p. H_rot: 2x1 derivative w.r.t. the rotation angle perturbation; H_p = R.
  Point2 Rotate(const Point2& p, Vector2* H_rot = nullptr, Matrix2* H_p = nullptr) const;
  // R^T * p. H_rot: 2x1 derivative w.r.t. the rotation angle perturbation; H_p = R^T.
  Point2 Unrotate(const Point2& p, Vector2* H_rot = nullptr, Matrix2* H_p = nullptr) const;

  // True when the angles differ by at most `tol` radians (modulo 2 pi, to first order).
  bool Equals(const Rot2& o, double tol = 1e-9) const;

 private:
  Rot2(double c, double s) : c_(c), s_(s) {}
  // One Newton step of 1/sqrt(c^2 + s^2) around 1: exact to O(err^2) for inputs that are unit
  // up to rounding, which is what products of unit rotations are.
  static Rot2 Renormalized(double c, double s) {
    const double k = 0.5 * (3.0 - (c * c + s * s));
    return Rot2(c * k, s * k);
  }

  double c_ = 1.0;
  double s_ = 0.0;
};

}  // namespace slamd::core
