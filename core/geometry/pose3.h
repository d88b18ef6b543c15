// Pose3: a rigid motion of 3-D space (SE(3)): rotation R_ then translation t_.
//
// Frames: a Pose3 T_wb maps points from its local (body) frame b to the world frame w:
// TransformFrom(p_b) = R p_b + t = p_w. Units: metres and radians.
//
// TANGENT ORDER: slamd orders se(3) tangent vectors as xi = (v, omega) = (translation, rotation),
// like Pose2 and like g2o's 6x6 information matrices. GTSAM orders Pose3 tangents as
// (omega, v): a GTSAM covariance or Jacobian maps to slamd by swapping the 3x3 blocks
// (P * M * P^T with P the block swap). Every Jacobian is with respect to a RIGHT perturbation
// X * Exp(d) of each group argument, and plain addition for points. Jacobian out-params are raw
// pointers; nullptr means "not wanted" and skips the work.
//
// Retract / LocalCoordinates use the true exponential map (X * Exp(xi), Log(X^-1 Y)).
// Pose3 is a small value type: cheap to copy, thread-compatible, never allocates.
#pragma once

#include "core/geometry/eigen_types.h"
#include "core/geometry/rot3.h"

namespace slamd::core {

class Pose3 {
 public:
  static constexpr int kDim = 6;

  // Identity.
  Pose3() = default;
  Pose3(const Rot3& R, const Point3& t) : R_(R), t_(t) {}

  const Rot3& rotation() const { return R_; }
  const Point3& translation() const { return t_; }
  // Homogeneous 4x4 matrix [[R, t], [0, 1]].
  Eigen::Matrix4d matrix() const;

  // this * b.
  Pose3 Compose(const Pose3& b, Matrix6* H1 = nullptr, Matrix6* H2 = nullptr) const;
  Pose3 operator*(const Pose3& b) const { return Compose(b); }
  // this^-1 * b (b expressed in this pose's frame).
  Pose3 Between(const Pose3& b, Matrix6* H1 = nullptr, Matrix6* H2 = nullptr) const;
  Pose3 Inverse(Matrix6* H = nullptr) const;

  // R p + t: local frame -> world frame.
  Point3 TransformFrom(const Point3& p, Matrix36* H_pose = nullptr, Matrix3* H_p = nullptr) const;
  // R^T (p - t): world frame -> local frame.
  Point3 TransformTo(const Point3& p, Matrix36* H_pose = nullptr, Matrix3* H_p = nullptr) const;

  // True SE(3) exponential of xi = (v, omega): R = Exp(omega), t = Jl(omega) v.
  // H = right Jacobian of SE(3), [[Jr(w), Q], [0, Jr(w)]] in (v, omega) order.
  static Pose3 Exp(const Vector6& xi, Matrix6* H = nullptr);
  // True SE(3) logarithm, rotation angle in [0, pi]; H = inverse right Jacobian.
  // Accurate near 0 (series) and near pi (quaternion-based rotation log, half-angle forms).
  static Vector6 Log(const Pose3& p, Matrix6* H = nullptr);

  // Ad such that X * Exp(xi) * X^-1 = Exp(Ad * xi), in (v, omega) order: [[R, [t]x R], [0, R]].
  Matrix6 AdjointMap() const;

  Pose3 Retract(const Vector6& xi) const { return Compose(Exp(xi)); }
  Vector6 LocalCoordinates(const Pose3& q) const { return Log(Between(q)); }

  // Rotation matrices and translations equal within `tol` (max absolute element difference).
  bool Equals(const Pose3& o, double tol = 1e-9) const;

 private:
  Rot3 R_;
  Point3 t_ = Point3::Zero();
};

}  // namespace slamd::core
