#include "core/factors/bearing_range_factor.h"

#include <cmath>

namespace slamd::core {

Result<FactorPtr> BearingRangeFactor::Decode(const FactorRecord& r, NoiseModel noise) {
  if (r.measured.size() != 2) {
    return InvalidArgument("measured: (bearing, range) is 2 numbers, not " +
                           std::to_string(r.measured.size()));
  }
  return FactorPtr(std::make_shared<const BearingRangeFactor>(
      r.keys[0], r.keys[1], r.measured[0], r.measured[1], std::move(noise), r.robust));
}

std::optional<Variable> BearingRangeFactor::Predict(int known, const Variable& known_value) const {
  if (known != 0) return std::nullopt;
  const Point2 local = range_ * Point2(std::cos(bearing_), std::sin(bearing_));
  return std::get<Pose2>(known_value).TransformFrom(local);
}

BearingRangeFactor::ErrorVector BearingRangeFactor::Evaluate(const Pose2& pose,
                                                             const Point2& landmark,
                                                             JacobianAt<0>* H1,
                                                             JacobianAt<1>* H2) const {
  Matrix23 Hd_pose;
  Matrix2 Hd_point;
  const Point2 d = pose.TransformTo(landmark, H1 ? &Hd_pose : nullptr, H2 ? &Hd_point : nullptr);
  const double r2 = d.squaredNorm();
  const double r = std::sqrt(r2);
  ErrorVector e(WrapAngle(std::atan2(d.y(), d.x()) - bearing_), r - range_);
  if (H1 || H2) {
    // ∂(bearing, range)/∂d for d = (dx, dy): [-dy/r², dx/r²; dx/r, dy/r].
    Matrix2 J = Matrix2::Zero();
    if (r > 0.0) J << -d.y() / r2, d.x() / r2, d.x() / r, d.y() / r;
    if (H1) *H1 = J * Hd_pose;
    if (H2) *H2 = J * Hd_point;
  }
  return e;
}

}  // namespace slamd::core
