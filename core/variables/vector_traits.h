// VariableTraits of the variables that move by addition (see variable_traits.h): points and
// camera calibrations. One template, told what its entries are and how it is plotted.
#pragma once

#include <array>
#include <optional>

#include "core/geometry/calibration.h"
#include "core/geometry/eigen_types.h"
#include "core/variables/variable_traits.h"

namespace slamd::core {
namespace internal {

// Traits of a type T whose tangent is its parameter vector (T::vector() or T itself).
template <typename T, int N, EntryKind kKind, bool kIsPoint>
struct VectorTraits {
  using Vector = Eigen::Matrix<double, N, 1>;
  static constexpr int kDim = N;
  static constexpr std::array<EntryKind, N> kEntryKinds = [] {
    std::array<EntryKind, N> kinds{};
    kinds.fill(kKind);
    return kinds;
  }();
  static const Vector& Params(const T& x) {
    if constexpr (kIsPoint) {
      return x;
    } else {
      return x.vector();
    }
  }
  static T Retract(const T& x, const double* d) {
    return T(Vector(Params(x) + Eigen::Map<const Vector>(d)));
  }
  static Vector Local(const T& a, const T& b) { return Params(b) - Params(a); }
  static bool AllFinite(const T& x) { return Params(x).allFinite(); }
  static constexpr int kEncodedSize = N;
  static void Encode(const T& x, double* out) { Eigen::Map<Vector>{out} = Params(x); }
  static std::optional<T> Decode(const double* in) {
    return T(Vector(Eigen::Map<const Vector>(in)));
  }
  static constexpr int kMessageSize = N;
  static void EncodeMessage(const T& x, double* out) { Encode(x, out); }
  static Eigen::Matrix<double, N, N> EstimateJacobian(const double*) {
    return Eigen::Matrix<double, N, N>::Identity();
  }
  static constexpr bool kPlotted = kIsPoint;
  static Vector2 PlanarPosition(const T& x) { return Params(x).template head<2>(); }
  static Matrix2 PlanarCovariance(const T&, const Eigen::MatrixXd& cov) {
    return cov.topLeftCorner<2, 2>();
  }
};

}  // namespace internal

template <>
struct VariableTraits<Point2> : internal::VectorTraits<Point2, 2, EntryKind::kTranslation, true> {
  static constexpr const char* kName = "Point2";
};
template <>
struct VariableTraits<Point3> : internal::VectorTraits<Point3, 3, EntryKind::kTranslation, true> {
  static constexpr const char* kName = "Point3";
};
template <>
struct VariableTraits<Cal3_S2>
    : internal::VectorTraits<Cal3_S2, 5, EntryKind::kCalibration, false> {
  static constexpr const char* kName = "Cal3_S2";
};
template <>
struct VariableTraits<Cal3DS2>
    : internal::VectorTraits<Cal3DS2, 9, EntryKind::kCalibration, false> {
  static constexpr const char* kName = "Cal3DS2";
};
template <>
struct VariableTraits<Cal3Bundler>
    : internal::VectorTraits<Cal3Bundler, 3, EntryKind::kCalibration, false> {
  static constexpr const char* kName = "Cal3Bundler";
};

}  // namespace slamd::core
