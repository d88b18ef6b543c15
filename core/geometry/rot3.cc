#include "core/geometry/rot3.h"

#include <Eigen/SVD>
#include <cmath>

#include "core/geometry/small_angle.h"

namespace slamd::core {
namespace {

// Shepperd's method: quaternion (w, v) of R from the largest of trace and diagonal, so the
// square root argument is always >= 1 and every component is accurate. Returns w >= 0.
void MatrixToQuaternion(const Matrix3& R, double* w, Vector3* v) {
  const double tr = R.trace();
  if (tr >= R(0, 0) && tr >= R(1, 1) && tr >= R(2, 2)) {
    const double t = std::sqrt(1.0 + tr);  // 2w
    const double f = 0.5 / t;
    *w = 0.5 * t;
    *v = Vector3(f * (R(2, 1) - R(1, 2)), f * (R(0, 2) - R(2, 0)), f * (R(1, 0) - R(0, 1)));
  } else {
    int i = 0;
    if (R(1, 1) > R(i, i)) i = 1;
    if (R(2, 2) > R(i, i)) i = 2;
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    const double t = std::sqrt(1.0 + R(i, i) - R(j, j) - R(k, k));  // 2|v_i|
    const double f = 0.5 / t;
    (*v)[i] = 0.5 * t;
    (*v)[j] = f * (R(j, i) + R(i, j));
    (*v)[k] = f * (R(k, i) + R(i, k));
    *w = f * (R(k, j) - R(j, k));
  }
  if (*w < 0.0) {
    *w = -*w;
    *v = -*v;
  }
}

// Coefficients of Rodrigues / Jr for angle t: a = sin t / t, b = (1 - cos t)/t^2,
// c = (t - sin t)/t^3.
struct So3Coeffs {
  double a, b, c;
};

So3Coeffs ComputeCoeffs(double t) {
  So3Coeffs k;
  const double t2 = t * t;
  if (t < kSmallAngle) {
    k.a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0));
    k.b = 0.5 * (1.0 - t2 / 12.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)));
    k.c = (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0))) / 6.0;
  } else {
    const double s = std::sin(t);
    const double sh = std::sin(0.5 * t);
    k.a = s / t;
    k.b = 2.0 * sh * sh / t2;  // 1 - cos t = 2 sin^2(t/2): no cancellation
    k.c = (t - s) / (t2 * t);
  }
  return k;
}

// Coefficient of [w]x^2 in Jr^-1: 1/t^2 - cot(t/2)/(2t), given t and cot(t/2).
double InverseCoeff(double t, double cot_half) {
  if (t < kSmallAngle) {
    const double t2 = t * t;
    return 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  }
  return 1.0 / (t * t) - 0.5 * cot_half / t;
}

// I + alpha [w]x + beta [w]x^2 without forming the products: [w]x^2 = w w^T - |w|^2 I.
Matrix3 IPlusSkewTerms(const Vector3& w, double alpha, double beta) {
  Matrix3 M = beta * (w * w.transpose());
  M.diagonal().array() += 1.0 - beta * w.squaredNorm();
  M(0, 1) -= alpha * w.z();
  M(1, 0) += alpha * w.z();
  M(0, 2) += alpha * w.y();
  M(2, 0) -= alpha * w.y();
  M(1, 2) -= alpha * w.x();
  M(2, 1) += alpha * w.x();
  return M;
}

}  // namespace

Rot3 Rot3::FromQuaternion(double w, double x, double y, double z) {
  return Rot3(Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix());
}

Eigen::Quaterniond Rot3::ToQuaternion() const {
  double w;
  Vector3 v;
  MatrixToQuaternion(R_, &w, &v);
  return Eigen::Quaterniond(w, v.x(), v.y(), v.z()).normalized();
}

Rot3 Rot3::FromRollPitchYaw(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll), sr = std::sin(roll);
  const double cp = std::cos(pitch), sp = std::sin(pitch);
  const double cy = std::cos(yaw), sy = std::sin(yaw);
  Matrix3 R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return Rot3(R);
}

Vector3 Rot3::RollPitchYaw() const {
  const double roll = std::atan2(R_(2, 1), R_(2, 2));
  const double pitch = std::atan2(-R_(2, 0), std::hypot(R_(2, 1), R_(2, 2)));
  const double yaw = std::atan2(R_(1, 0), R_(0, 0));
  return Vector3(WrapAngle(roll), pitch, WrapAngle(yaw));
}

Rot3 Rot3::Compose(const Rot3& b, Matrix3* H1, Matrix3* H2) const {
  if (H1) *H1 = b.R_.transpose();  // Ad(b^-1)
  if (H2) H2->setIdentity();
  return Rot3(R_ * b.R_);
}

Rot3 Rot3::Between(const Rot3& b, Matrix3* H1, Matrix3* H2) const {
  const Matrix3 C = R_.transpose() * b.R_;
  if (H1) *H1 = -C.transpose();  // -Ad(C^-1)
  if (H2) H2->setIdentity();
  return Rot3(C);
}

Rot3 Rot3::Inverse(Matrix3* H) const {
  if (H) *H = -R_;  // -Ad(R)
  return Rot3(R_.transpose());
}

Point3 Rot3::Rotate(const Point3& p, Matrix3* H_rot, Matrix3* H_p) const {
  // R Exp(d) p ~ R (p + d x p) = R p - R [p]x d.
  if (H_rot) *H_rot = -R_ * Skew(p);
  if (H_p) *H_p = R_;
  return R_ * p;
}

Point3 Rot3::Unrotate(const Point3& p, Matrix3* H_rot, Matrix3* H_p) const {
  const Point3 q = R_.transpose() * p;
  // (R Exp(d))^T p = Exp(-d) q ~ q - d x q = q + [q]x d.
  if (H_rot) *H_rot = Skew(q);
  if (H_p) *H_p = R_.transpose();
  return q;
}

Rot3 Rot3::Exp(const Vector3& w, Matrix3* H) {
  const So3Coeffs k = ComputeCoeffs(w.norm());
  if (H) *H = IPlusSkewTerms(w, -k.b, k.c);
  return Rot3(IPlusSkewTerms(w, k.a, k.b));
}

Vector3 Rot3::Log(const Rot3& rot, Matrix3* H) {
  double qw;
  Vector3 qv;
  MatrixToQuaternion(rot.R_, &qw, &qv);
  // q = (cos(t/2), sin(t/2) n) up to scale, so t = 2 atan2(|v|, w) in [0, pi].
  const double nv = qv.norm();
  double scale, t;
  if (nv < 1e-6 * qw) {
    // atan(x)/x = 1 - x^2/3 + O(x^4), x = nv/qw <= 1e-6.
    const double x2 = nv * nv / (qw * qw);
    scale = 2.0 / qw * (1.0 - x2 / 3.0);
    t = scale * nv;
  } else {
    t = 2.0 * std::atan2(nv, qw);
    scale = t / nv;
  }
  const Vector3 w = scale * qv;
  if (H) {
    // cot(t/2) = qw / nv, exact from the quaternion even when t is near pi.
    const double beta = t < kSmallAngle ? InverseCoeff(t, 0.0) : InverseCoeff(t, qw / nv);
    *H = IPlusSkewTerms(w, 0.5, beta);
  }
  return w;
}

Matrix3 Rot3::RightJacobian(const Vector3& w) {
  const So3Coeffs k = ComputeCoeffs(w.norm());
  return IPlusSkewTerms(w, -k.b, k.c);
}

Matrix3 Rot3::RightJacobianInverse(const Vector3& w) {
  const double t = w.norm();
  const double beta = t < kSmallAngle ? InverseCoeff(t, 0.0)
                                      : InverseCoeff(t, std::cos(0.5 * t) / std::sin(0.5 * t));
  return IPlusSkewTerms(w, 0.5, beta);
}

Rot3 Rot3::Normalized() const {
  // Polar decomposition: U V^T is the orthonormal matrix closest in Frobenius norm; flip the
  // last singular direction if needed so det = +1. Fixed-size SVD: no heap allocation.
  const Eigen::JacobiSVD<Matrix3> svd(R_, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3 U = svd.matrixU();
  const Matrix3& V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0.0) U.col(2) = -U.col(2);
  return Rot3(U * V.transpose());
}

bool Rot3::Equals(const Rot3& o, double tol) const {
  return (R_ - o.R_).cwiseAbs().maxCoeff() <= tol;
}

}  // namespace slamd::core
