#include "core/geometry/pose2.h"

#include <cmath>

#include "core/geometry/small_angle.h"

namespace slamd::core {
namespace {

// Coefficients of the SE(2) exponential and its Jacobian for angle th:
//   A = sin(th)/th, B = (1-cos th)/th, a = (th - sin th)/th^2, b = (1-cos th)/th^2.
struct Se2Coeffs {
  double A, B, a, b;
};

Se2Coeffs ComputeCoeffs(double th, double s) {
  Se2Coeffs k;
  const double th2 = th * th;
  if (std::abs(th) < kSmallAngle) {
    k.A = 1.0 - th2 / 6.0 * (1.0 - th2 / 20.0 * (1.0 - th2 / 42.0));
    k.b = 0.5 * (1.0 - th2 / 12.0 * (1.0 - th2 / 30.0 * (1.0 - th2 / 56.0)));
    k.a = th / 6.0 * (1.0 - th2 / 20.0 * (1.0 - th2 / 42.0 * (1.0 - th2 / 72.0)));
  } else {
    k.A = s / th;
    // 1 - cos th = 2 sin^2(th/2) avoids cancellation for moderate th.
    const double sh = std::sin(0.5 * th);
    k.b = 2.0 * sh * sh / th2;
    k.a = (th - s) / th2;
  }
  k.B = k.b * th;
  return k;
}

// Jr(xi) = [[A, B, r0 a - r1 b], [-B, A, r0 b + r1 a], [0, 0, 1]] for xi = (r0, r1, th).
void RightJacobian(const Se2Coeffs& k, double r0, double r1, Matrix3* H) {
  *H << k.A, k.B, r0 * k.a - r1 * k.b,  //
      -k.B, k.A, r0 * k.b + r1 * k.a,   //
      0.0, 0.0, 1.0;
}

// Ad([R, t]) = [[R, (t.y, -t.x)], [0, 1]].
void Adjoint(const Rot2& r, const Point2& t, Matrix3* H) {
  *H << r.c(), -r.s(), t.y(),  //
      r.s(), r.c(), -t.x(),    //
      0.0, 0.0, 1.0;
}

}  // namespace

Matrix3 Pose2::matrix() const {
  Matrix3 T;
  T << r_.c(), -r_.s(), t_.x(),  //
      r_.s(), r_.c(), t_.y(),    //
      0.0, 0.0, 1.0;
  return T;
}

Pose2 Pose2::Compose(const Pose2& b, Matrix3* H1, Matrix3* H2) const {
  // H1 = Ad(b^-1), H2 = I.
  if (H1) {
    const Point2 tinv = -b.r_.Unrotate(b.t_);
    Adjoint(b.r_.Inverse(), tinv, H1);
  }
  if (H2) H2->setIdentity();
  return Pose2(r_ * b.r_, t_ + r_.Rotate(b.t_));
}

Pose2 Pose2::Between(const Pose2& b, Matrix3* H1, Matrix3* H2) const {
  const Pose2 d(r_.Between(b.r_), r_.Unrotate(b.t_ - t_));
  // H1 = -Ad(d^-1), H2 = I.
  if (H1) {
    const Point2 tinv = -d.r_.Unrotate(d.t_);
    Adjoint(d.r_.Inverse(), tinv, H1);
    *H1 = -*H1;
  }
  if (H2) H2->setIdentity();
  return d;
}

Pose2 Pose2::Inverse(Matrix3* H) const {
  if (H) {
    Adjoint(r_, t_, H);
    *H = -*H;
  }
  return Pose2(r_.Inverse(), -r_.Unrotate(t_));
}

Point2 Pose2::TransformFrom(const Point2& p, Matrix23* H_pose, Matrix2* H_p) const {
  // d/dd [R (p + dv + dw J p) + t] = [R, R J p].
  if (H_pose) {
    const double c = r_.c(), s = r_.s();
    // R J p = R (-p.y, p.x).
    (*H_pose) << c, -s, -c * p.y() - s * p.x(),  //
        s, c, -s * p.y() + c * p.x();
  }
  if (H_p) *H_p = r_.matrix();
  return r_.Rotate(p) + t_;
}

Point2 Pose2::TransformTo(const Point2& p, Matrix23* H_pose, Matrix2* H_p) const {
  const Point2 q = r_.Unrotate(p - t_);
  // (X Exp(d))^-1 p = Exp(-d) q ~ q - dv - dw J q  =>  [-I, (q.y, -q.x)].
  if (H_pose) {
    (*H_pose) << -1.0, 0.0, q.y(),  //
        0.0, -1.0, -q.x();
  }
  if (H_p) *H_p = r_.matrix().transpose();
  return q;
}

Pose2 Pose2::Exp(const Vector3& xi, Matrix3* H) {
  const double th = xi[2];
  const double s = std::sin(th), c = std::cos(th);
  const Se2Coeffs k = ComputeCoeffs(th, s);
  // t = V v with V = [[A, -B], [B, A]].
  const Point2 t(k.A * xi[0] - k.B * xi[1], k.B * xi[0] + k.A * xi[1]);
  if (H) RightJacobian(k, xi[0], xi[1], H);
  return Pose2(Rot2::FromCosSin(c, s), t);
}

Vector3 Pose2::Log(const Pose2& p, Matrix3* H) {
  const double th = p.theta();
  const double c = p.r_.c(), s = p.r_.s();
  // V^-1 = [[al, th/2], [-th/2, al]], al = (th/2) cot(th/2). cot(th/2) equals (1+c)/s and
  // s/(1-c); pick the form whose denominator is far from 0 (near 0 and near pi respectively).
  double al;
  if (std::abs(th) < kSmallAngle) {
    const double th2 = th * th;
    al = 1.0 - th2 / 12.0 * (1.0 + th2 / 60.0);
  } else if (c >= 0.0) {
    al = 0.5 * th * (1.0 + c) / s;
  } else {
    al = 0.5 * th * s / (1.0 - c);
  }
  const double h = 0.5 * th;
  const Point2& t = p.t_;
  const Vector3 xi(al * t.x() + h * t.y(), -h * t.x() + al * t.y(), th);
  if (H) {
    // Jr = [[M, c3], [0, 1]] with M = V^T, so Jr^-1 = [[M^-1, -M^-1 c3], [0, 1]] and
    // M^-1 = (V^-1)^T = [[al, -th/2], [th/2, al]].
    const Se2Coeffs k = ComputeCoeffs(th, s);
    const double c30 = xi[0] * k.a - xi[1] * k.b;
    const double c31 = xi[0] * k.b + xi[1] * k.a;
    (*H) << al, -h, -(al * c30 - h * c31),  //
        h, al, -(h * c30 + al * c31),       //
        0.0, 0.0, 1.0;
  }
  return xi;
}

Matrix3 Pose2::AdjointMap() const {
  Matrix3 A;
  Adjoint(r_, t_, &A);
  return A;
}

Vector3 Pose2::ChartLocal(const Pose2& p, Matrix3* H) {
  if (H) {
    (*H) << p.r_.c(), -p.r_.s(), 0.0,  //
        p.r_.s(), p.r_.c(), 0.0,       //
        0.0, 0.0, 1.0;
  }
  return Vector3(p.t_.x(), p.t_.y(), p.theta());
}

bool Pose2::Equals(const Pose2& o, double tol) const {
  return std::abs(t_.x() - o.t_.x()) <= tol && std::abs(t_.y() - o.t_.y()) <= tol &&
         r_.Equals(o.r_, tol);
}

}  // namespace slamd::core
