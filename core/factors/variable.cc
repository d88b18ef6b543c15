#include "core/factors/variable.h"

#include "core/base/check.h"

namespace slamd::core {

const char* VariableTypeName(VariableType type) {
  switch (type) {
    case VariableType::kPose2: return "Pose2";
    case VariableType::kPose3: return "Pose3";
    case VariableType::kPoint2: return "Point2";
    case VariableType::kPoint3: return "Point3";
  }
  return "unknown";
}

void RetractInPlace(Variable* v, const double* delta) {
  switch (TypeOf(*v)) {
    case VariableType::kPose2: {
      Pose2& p = std::get<Pose2>(*v);
      p = p.Retract(Eigen::Map<const Vector3>(delta));
      break;
    }
    case VariableType::kPose3: {
      Pose3& p = std::get<Pose3>(*v);
      p = p.Retract(Eigen::Map<const Vector6>(delta));
      break;
    }
    case VariableType::kPoint2: std::get<Point2>(*v) += Eigen::Map<const Vector2>(delta); break;
    case VariableType::kPoint3: std::get<Point3>(*v) += Eigen::Map<const Vector3>(delta); break;
  }
}

Eigen::VectorXd LocalCoordinates(const Variable& a, const Variable& b) {
  SLAMD_CHECK(a.index() == b.index()) << "LocalCoordinates between different variable types";
  switch (TypeOf(a)) {
    case VariableType::kPose2: return std::get<Pose2>(a).LocalCoordinates(std::get<Pose2>(b));
    case VariableType::kPose3: return std::get<Pose3>(a).LocalCoordinates(std::get<Pose3>(b));
    case VariableType::kPoint2: return std::get<Point2>(b) - std::get<Point2>(a);
    case VariableType::kPoint3: return std::get<Point3>(b) - std::get<Point3>(a);
  }
  return {};
}

bool AllFinite(const Variable& v) {
  switch (TypeOf(v)) {
    case VariableType::kPose2: {
      const Pose2& p = std::get<Pose2>(v);
      return p.translation().allFinite() && std::isfinite(p.theta());
    }
    case VariableType::kPose3: {
      const Pose3& p = std::get<Pose3>(v);
      return p.translation().allFinite() && p.rotation().matrix().allFinite();
    }
    case VariableType::kPoint2: return std::get<Point2>(v).allFinite();
    case VariableType::kPoint3: return std::get<Point3>(v).allFinite();
  }
  return false;
}

}  // namespace slamd::core
