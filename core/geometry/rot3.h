// Rot3: a rotation of 3-D space (SO(3)).
//
// Stored as an orthonormal 3x3 matrix (not a quaternion) because the solvers mostly compose,
// rotate points and build Jacobians: with a matrix, Compose is one 3x3 product, Rotate one
// matrix-vector product, and the Jacobians are the matrix itself or products with Skew(.), with
// no quaternion-to-matrix conversion per call. Products of rotations drift from orthonormality by
// O(eps) per operation; call Normalized() after very long chains.
//
// Tangent vectors are rotation vectors w (axis * angle, radians). Every Jacobian is with respect
// to a RIGHT perturbation R * Exp(d), and plain addition for points. Jacobian out-params are raw
// pointers; nullptr means "not wanted" and skips the work.
// Rot3 is a small value type: cheap to copy, thread-compatible, never allocates.
#pragma once

#include <Eigen/Geometry>

#include "core/geometry/eigen_types.h"

namespace slamd::core {

// [w]x: the matrix with Skew(w) * p = w.cross(p).
inline Matrix3 Skew(const Vector3& w) {
  Matrix3 S;
  S << 0.0, -w.z(), w.y(),  //
      w.z(), 0.0, -w.x(),   //
      -w.y(), w.x(), 0.0;
  return S;
}

class Rot3 {
 public:
  static constexpr int kDim = 3;

  // Identity.
  Rot3() : R_(Matrix3::Identity()) {}
  // The caller guarantees that R is orthonormal with det +1 (not checked).
  explicit Rot3(const Matrix3& R) : R_(R) {}

  // From a quaternion (w, x, y, z); normalised first, so any non-zero quaternion is accepted.
  static Rot3 FromQuaternion(double w, double x, double y, double z);
  // Unit quaternion with w >= 0 (q and -q are the same rotation; this picks one).
  Eigen::Quaterniond ToQuaternion() const;
  // R = Rz(yaw) * Ry(pitch) * Rx(roll), radians.
  static Rot3 FromRollPitchYaw(double roll, double pitch, double yaw);
  // (roll, pitch, yaw) with roll, yaw in (-pi, pi] and pitch in [-pi/2, pi/2]. Ill-conditioned
  // near |pitch| = pi/2 (gimbal lock), where only roll +- yaw is determined.
  Vector3 RollPitchYaw() const;
  const Matrix3& matrix() const { return R_; }

  // this * b.
  Rot3 Compose(const Rot3& b, Matrix3* H1 = nullptr, Matrix3* H2 = nullptr) const;
  Rot3 operator*(const Rot3& b) const { return Rot3(R_ * b.R_); }
  // this^-1 * b.
  Rot3 Between(const Rot3& b, Matrix3* H1 = nullptr, Matrix3* H2 = nullptr) const;
  Rot3 Inverse(Matrix3* H = nullptr) const;

  // R p. H_rot = -R [p]x, H_p = R.
  Point3 Rotate(const Point3& p, Matrix3* H_rot = nullptr, Matrix3* H_p = nullptr) const;
  // R^T p. H_rot = [R^T p]x, H_p = R^T.
  Point3 Unrotate(const Point3& p, Matrix3* H_rot = nullptr, Matrix3* H_p = nullptr) const;

  // Rodrigues' formula (series expansion for small |w|); H = Jr(w).
  static Rot3 Exp(const Vector3& w, Matrix3* H = nullptr);
  // Rotation vector with angle in [0, pi]; H = Jr^-1(Log R). Goes through the quaternion
  // (Shepperd's method: largest of trace/diagonal), so it is accurate to O(eps) for every angle,
  // including near 0 and near pi. At exactly pi the sign of the axis is arbitrary.
  static Vector3 Log(const Rot3& R, Matrix3* H = nullptr);
  // Jr(w) = I - (1-cos t)/t^2 [w]x + (t - sin t)/t^3 [w]x^2, t = |w|.
  static Matrix3 RightJacobian(const Vector3& w);
  // Jr^-1(w) = I + 1/2 [w]x + (1/t^2 - cot(t/2)/(2t)) [w]x^2; singular at t = 2 pi.
  static Matrix3 RightJacobianInverse(const Vector3& w);

  Rot3 Retract(const Vector3& w) const { return *this * Exp(w); }
  Vector3 LocalCoordinates(const Rot3& q) const { return Log(Between(q)); }

  // The rotation nearest (Frobenius norm) to a drifted, nearly orthonormal matrix (via SVD).
  Rot3 Normalized() const;
  // Max absolute element difference of the matrices <= tol.
  bool Equals(const Rot3& o, double tol = 1e-9) const;

 private:
  Matrix3 R_;
};

}  // namespace slamd::core
