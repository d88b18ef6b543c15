// Pose2: a rigid motion of the plane (SE(2)): rotation r_ then translation t_.
//
// Frames: a Pose2 T_wb maps points from its local (body) frame b to the world frame w:
// TransformFrom(p_b) = R p_b + t = p_w. Units: metres and radians.
//
// Tangent coordinates are ordered (vx, vy, omega): translation first, as in g2o's information
// matrices. Every Jacobian is with respect to a RIGHT perturbation X * Exp(d) of each group
// argument, and plain addition for points. Jacobian out-params are raw pointers; nullptr means
// "not wanted" and skips the work.
//
// Two local parameterisations exist, on purpose:
//  * Exp / Log: the true SE(2) exponential and logarithm (used by Jacobian definitions, tests and
//    anything needing geometric correctness).
//  * Retract / LocalCoordinates / ChartLocal: the cheap chart that optimisation uses. It matches
//    GTSAM's default Pose2 chart, X.Retract(d) = X * Pose2(d[0], d[1], d[2]), so that errors and
//    chi2 values computed by slamd agree with GTSAM's. Both charts agree to first order at 0.
// Pose2 is a small value type: cheap to copy, thread-compatible, never allocates.
#pragma once

#include "core/geometry/eigen_types.h"
#include "core/geometry/rot2.h"

namespace slamd::core {

class Pose2 {
 public:
  static constexpr int kDim = 3;

  // Identity.
  Pose2() = default;
  Pose2(double x, double y, double theta) : r_(Rot2::FromAngle(theta)), t_(x, y) {}
  Pose2(const Rot2& r, const Point2& t) : r_(r), t_(t) {}

  double x() const { return t_.x(); }
  double y() const { return t_.y(); }
  // In (-pi, pi].
  double theta() const { return r_.theta(); }
  const Point2& translation() const { return t_; }
  const Rot2& rotation() const { return r_; }
  // Homogeneous 3x3 matrix [[R, t], [0, 1]].
  Matrix3 matrix() const;

  // this * b.
  Pose2 Compose(const Pose2& b, Matrix3* H1 = nullptr, Matrix3* H2 = nullptr) const;
  Pose2 operator*(const Pose2& b) const { return Compose(b); }
  // this^-1 * b (b expressed in this pose's frame).
  Pose2 Between(const Pose2& b, Matrix3* H1 = nullptr, Matrix3* H2 = nullptr) const;
  Pose2 Inverse(Matrix3* H = nullptr) const;

  // this * p = R p + t: local frame -> world frame.
  Point2 TransformFrom(const Point2& p, Matrix23* H_pose = nullptr, Matrix2* H_p = nullptr) const;
  // this^-1 * p = R^T (p - t): world frame -> local frame.
  Point2 TransformTo(const Point2& p, Matrix23* H_pose = nullptr, Matrix2* H_p = nullptr) const;

  // True SE(2) exponential of xi = (vx, vy, omega); H = right Jacobian Jr(xi).
  static Pose2 Exp(const Vector3& xi, Matrix3* H = nullptr);
  // True SE(2) logarithm, omega in (-pi, pi]; H = Jr^-1(Log p). Accurate for any angle,
  // including theta near 0 (series expansions) and near pi (half-angle forms).
  static Vector3 Log(const Pose2& p, Matrix3* H = nullptr);

  // Ad such that X * Exp(xi) * X^-1 = Exp(Ad * xi), in (vx, vy, omega) order.
  Matrix3 AdjointMap() const;

  // --- Optimisation chart (GTSAM's default Pose2 chart) ---
  // (x, y, theta) of p. H = d ChartLocal(p * Exp(d)) / dd at d = 0 = blockdiag(R, 1).
  static Vector3 ChartLocal(const Pose2& p, Matrix3* H = nullptr);
  // this * Pose2(d[0], d[1], d[2]).
  Pose2 Retract(const Vector3& d) const { return Compose(Pose2(d[0], d[1], d[2])); }
  // ChartLocal(this^-1 * q); the inverse of Retract (theta component in (-pi, pi]).
  Vector3 LocalCoordinates(const Pose2& q) const { return ChartLocal(Between(q)); }

  // Translations within `tol` per coordinate and angles within `tol` radians.
  bool Equals(const Pose2& o, double tol = 1e-9) const;

 private:
  Rot2 r_;
  Point2 t_ = Point2::Zero();
};

}  // namespace slamd::core
