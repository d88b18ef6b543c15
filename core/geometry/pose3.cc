#include "core/geometry/pose3.h"

#include <cmath>

#include "core/geometry/small_angle.h"

namespace slamd::core {
namespace {

// The off-diagonal block of the SE(3) right Jacobian in (v, omega) order, Q_r(v, w) = Q(-v, -w),
// where Q is Barfoot's left-Jacobian block ("State Estimation for Robotics", sec. 7.1.5):
//   Q(r, p) = 1/2 R + a2 (P R + R P + P R P) + a3 (P P R + R P P - 3 P R P)
//             + a4 (P R P P + P P R P),   R = [r]x, P = [p]x, t = |p|,
//   a2 = (t - sin t)/t^3, a3 = (t^2 + 2 cos t - 2)/(2 t^4), a4 = (2t - 3 sin t + t cos t)/(2 t^5).
// Negating both arguments flips the sign of the odd-degree terms.
Matrix3 RightQ(const Vector3& v, const Vector3& w) {
  const double t = w.norm();
  const double t2 = t * t;
  double a2, a3, a4;
  if (t < kSmallAngle) {
    a2 = (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0))) / 6.0;
    a3 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0;
    a4 = 1.0 / 120.0 - t2 / 2520.0 + t2 * t2 / 120960.0;
  } else {
    const double s = std::sin(t), c = std::cos(t);
    const double t4 = t2 * t2;
    a2 = (t - s) / (t2 * t);
    a3 = (t2 + 2.0 * c - 2.0) / (2.0 * t4);
    a4 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t4 * t);
  }
  const Matrix3 V = Skew(v);
  const Matrix3 P = Skew(w);
  const Matrix3 PV = P * V;
  const Matrix3 VP = V * P;
  const Matrix3 PVP = PV * P;
  return -0.5 * V + a2 * (PV + VP - PVP) + a3 * (3.0 * PVP - P * PV - VP * P) +
         a4 * (PVP * P + P * PVP);
}

// Ad([R, t]) in (v, omega) order.
void Adjoint(const Matrix3& R, const Point3& t, Matrix6* A) {
  A->topLeftCorner<3, 3>() = R;
  A->topRightCorner<3, 3>() = Skew(t) * R;
  A->bottomLeftCorner<3, 3>().setZero();
  A->bottomRightCorner<3, 3>() = R;
}

// Ad(X^-1) for X = [R, t]: [[R^T, -R^T [t]x], [0, R^T]], without forming X^-1.
void AdjointOfInverse(const Matrix3& R, const Point3& t, Matrix6* A) {
  const Matrix3 Rt = R.transpose();
  A->topLeftCorner<3, 3>() = Rt;
  A->topRightCorner<3, 3>() = -Rt * Skew(t);
  A->bottomLeftCorner<3, 3>().setZero();
  A->bottomRightCorner<3, 3>() = Rt;
}

}  // namespace

Eigen::Matrix4d Pose3::matrix() const {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R_.matrix();
  T.topRightCorner<3, 1>() = t_;
  return T;
}

Pose3 Pose3::Compose(const Pose3& b, Matrix6* H1, Matrix6* H2) const {
  if (H1) AdjointOfInverse(b.R_.matrix(), b.t_, H1);
  if (H2) H2->setIdentity();
  return Pose3(R_ * b.R_, t_ + R_.matrix() * b.t_);
}

Pose3 Pose3::Between(const Pose3& b, Matrix6* H1, Matrix6* H2) const {
  const Matrix3 Rt = R_.matrix().transpose();
  const Pose3 d(Rot3(Rt * b.R_.matrix()), Rt * (b.t_ - t_));
  if (H1) {
    AdjointOfInverse(d.R_.matrix(), d.t_, H1);
    *H1 = -*H1;
  }
  if (H2) H2->setIdentity();
  return d;
}

Pose3 Pose3::Inverse(Matrix6* H) const {
  if (H) {
    Adjoint(R_.matrix(), t_, H);
    *H = -*H;
  }
  const Matrix3 Rt = R_.matrix().transpose();
  return Pose3(Rot3(Rt), -(Rt * t_));
}

Point3 Pose3::TransformFrom(const Point3& p, Matrix36* H_pose, Matrix3* H_p) const {
  const Matrix3& R = R_.matrix();
  // X Exp(d) p ~ R (p + dv + dw x p) + t  =>  [R, -R [p]x].
  if (H_pose) {
    H_pose->leftCols<3>() = R;
    H_pose->rightCols<3>() = -R * Skew(p);
  }
  if (H_p) *H_p = R;
  return R * p + t_;
}

Point3 Pose3::TransformTo(const Point3& p, Matrix36* H_pose, Matrix3* H_p) const {
  const Matrix3& R = R_.matrix();
  const Point3 q = R.transpose() * (p - t_);
  // (X Exp(d))^-1 p = Exp(-d) q ~ q - dv - dw x q  =>  [-I, [q]x].
  if (H_pose) {
    H_pose->leftCols<3>() = -Matrix3::Identity();
    H_pose->rightCols<3>() = Skew(q);
  }
  if (H_p) *H_p = R.transpose();
  return q;
}

Pose3 Pose3::Exp(const Vector6& xi, Matrix6* H) {
  const Vector3 v = xi.head<3>();
  const Vector3 w = xi.tail<3>();
  Matrix3 Jr;
  const Rot3 R = Rot3::Exp(w, H ? &Jr : nullptr);
  // t = Jl(w) v with Jl(w) = Jr(w)^T = Jr(-w) = I + b [w]x + c [w]x^2; computed through the
  // rotation: Jl(w) v = v + b w x v + c w x (w x v), with b, c as in Rot3::Exp.
  const double th = w.norm();
  double b, c;
  if (th < kSmallAngle) {
    const double t2 = th * th;
    b = 0.5 * (1.0 - t2 / 12.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)));
    c = (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0))) / 6.0;
  } else {
    const double sh = std::sin(0.5 * th);
    b = 2.0 * sh * sh / (th * th);
    c = (th - std::sin(th)) / (th * th * th);
  }
  const Vector3 wxv = w.cross(v);
  const Point3 t = v + b * wxv + c * w.cross(wxv);
  if (H) {
    H->topLeftCorner<3, 3>() = Jr;
    H->topRightCorner<3, 3>() = RightQ(v, w);
    H->bottomLeftCorner<3, 3>().setZero();
    H->bottomRightCorner<3, 3>() = Jr;
  }
  return Pose3(R, t);
}

Vector6 Pose3::Log(const Pose3& p, Matrix6* H) {
  Matrix3 Jinv;
  const Vector3 w = Rot3::Log(p.R_, &Jinv);
  // v = Jl(w)^-1 t = Jr^-1(w)^T t (Jr^-1 is I + 1/2 W + beta W^2, so its transpose flips W).
  const Point3 v = Jinv.transpose() * p.t_;
  Vector6 xi;
  xi << v, w;
  if (H) {
    // Jr^-1 of SE(3) = [[Jinv, -Jinv Q Jinv], [0, Jinv]].
    H->topLeftCorner<3, 3>() = Jinv;
    H->topRightCorner<3, 3>() = -Jinv * RightQ(v, w) * Jinv;
    H->bottomLeftCorner<3, 3>().setZero();
    H->bottomRightCorner<3, 3>() = Jinv;
  }
  return xi;
}

Matrix6 Pose3::AdjointMap() const {
  Matrix6 A;
  Adjoint(R_.matrix(), t_, &A);
  return A;
}

bool Pose3::Equals(const Pose3& o, double tol) const {
  return R_.Equals(o.R_, tol) && (t_ - o.t_).cwiseAbs().maxCoeff() <= tol;
}

}  // namespace slamd::core
