#include "core/factors/predict.h"

#include <cmath>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"

namespace slamd::core {
namespace {

template <typename T>
std::optional<Variable> PredictOtherPose(const BetweenFactor<T>& f, int known, const Variable& x) {
  SLAMD_CHECK(std::holds_alternative<T>(x)) << f.Name() << ": the known value has the wrong type";
  const T& z = f.measured();
  return std::get<T>(x).Compose(known == 0 ? z : z.Inverse());
}

}  // namespace

std::optional<Variable> PredictFromFactor(const Factor& factor, int known, const Variable& known_value) {
  if (const auto* f = dynamic_cast<const BetweenFactor<Pose2>*>(&factor)) {
    return PredictOtherPose(*f, known, known_value);
  }
  if (const auto* f = dynamic_cast<const BetweenFactor<Pose3>*>(&factor)) {
    return PredictOtherPose(*f, known, known_value);
  }
  if (known != 0) return std::nullopt;  // a landmark does not place its pose
  if (const auto* f = dynamic_cast<const RelativePointFactor<Pose2, Point2>*>(&factor)) {
    return std::get<Pose2>(known_value).TransformFrom(f->measured());
  }
  if (const auto* f = dynamic_cast<const RelativePointFactor<Pose3, Point3>*>(&factor)) {
    return std::get<Pose3>(known_value).TransformFrom(f->measured());
  }
  if (const auto* f = dynamic_cast<const BearingRangeFactor*>(&factor)) {
    const Point2 local = f->range() * Point2(std::cos(f->bearing()), std::sin(f->bearing()));
    return std::get<Pose2>(known_value).TransformFrom(local);
  }
  return std::nullopt;
}

}  // namespace slamd::core
