#include "core/geometry/rot2.h"

#include <cmath>
#include <limits>

namespace slamd::core {

Rot2 Rot2::FromCosSin(double c, double s) {
  const double n = std::hypot(c, s);
  if (n == 0.0) return Rot2();
  // Unit length to rounding: kept, so that a stored (cos, sin) reads back bit for bit (dividing
  // by hypot's 1 ± ulp would change the last bit, and a journal replay would drift from the run).
  if (std::abs(n - 1.0) <= 4 * std::numeric_limits<double>::epsilon()) return Rot2(c, s);
  return Rot2(c / n, s / n);
}

double Rot2::theta() const {
  const double t = std::atan2(s_, c_);
  // atan2 returns -pi for (c < 0, s = -0.0); the contract is (-pi, pi].
  return t == -kPi ? kPi : t;
}

Matrix2 Rot2::matrix() const {
  Matrix2 R;
  R << c_, -s_, s_, c_;
  return R;
}

Point2 Rot2::Rotate(const Point2& p, Vector2* H_rot, Matrix2* H_p) const {
  const Point2 q(c_ * p.x() - s_ * p.y(), s_ * p.x() + c_ * p.y());
  // d/dd R Exp(d) p = R J p = J R p with J = [[0, -1], [1, 0]] (planar rotations commute).
  if (H_rot) *H_rot = Vector2(-q.y(), q.x());
  if (H_p) *H_p = matrix();
  return q;
}

Point2 Rot2::Unrotate(const Point2& p, Vector2* H_rot, Matrix2* H_p) const {
  const Point2 q(c_ * p.x() + s_ * p.y(), -s_ * p.x() + c_ * p.y());
  // (R Exp(d))^T p = Exp(-d) R^T p, so the derivative is -J q.
  if (H_rot) *H_rot = Vector2(q.y(), -q.x());
  if (H_p) *H_p = matrix().transpose();
  return q;
}

bool Rot2::Equals(const Rot2& o, double tol) const {
  // sin of the angle difference (= angle difference to first order) and its cosine sign.
  const double sd = c_ * o.s_ - s_ * o.c_;
  const double cd = c_ * o.c_ + s_ * o.s_;
  return cd > 0.0 && std::abs(sd) <= tol;
}

}  // namespace slamd::core
