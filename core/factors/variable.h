// The kinds of variable a factor graph holds, and their traits: tangent dimension, the chart
// (retract / local coordinates) the optimiser moves them with.
//
// Poses move on the right: X ⊕ δ = X.Retract(δ) (see pose2.h and pose3.h for the tangent order,
// translation first). Points move by plain addition.
#pragma once

#include <variant>

#include "core/geometry/eigen_types.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"

namespace slamd::core {

// One value of any supported kind. The order of alternatives is VariableType's order.
using Variable = std::variant<Pose2, Pose3, Point2, Point3>;

enum class VariableType : unsigned char { kPose2 = 0, kPose3 = 1, kPoint2 = 2, kPoint3 = 3 };

inline constexpr int kMaxVariableDim = 6;

constexpr int TangentDim(VariableType type) {
  constexpr int kDims[] = {3, 6, 2, 3};
  return kDims[static_cast<int>(type)];
}
const char* VariableTypeName(VariableType type);

inline VariableType TypeOf(const Variable& v) { return static_cast<VariableType>(v.index()); }

// Compile-time traits of each alternative.
template <typename T>
struct VariableTraits;
template <>
struct VariableTraits<Pose2> {
  static constexpr int kDim = 3;
  static constexpr VariableType kType = VariableType::kPose2;
};
template <>
struct VariableTraits<Pose3> {
  static constexpr int kDim = 6;
  static constexpr VariableType kType = VariableType::kPose3;
};
template <>
struct VariableTraits<Point2> {
  static constexpr int kDim = 2;
  static constexpr VariableType kType = VariableType::kPoint2;
};
template <>
struct VariableTraits<Point3> {
  static constexpr int kDim = 3;
  static constexpr VariableType kType = VariableType::kPoint3;
};

// v ← v ⊕ delta, where delta points at TangentDim(TypeOf(v)) doubles.
void RetractInPlace(Variable* v, const double* delta);
// The tangent vector d with a ⊕ d = b (same type required; checked).
Eigen::VectorXd LocalCoordinates(const Variable& a, const Variable& b);
bool AllFinite(const Variable& v);

}  // namespace slamd::core
