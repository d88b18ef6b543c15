// VariableTraits of the poses (see variable_traits.h). Tangent order is translation first, as in
// pose2.h and pose3.h.
#pragma once

#include <array>
#include <cmath>
#include <optional>

#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"
#include "core/variables/variable_traits.h"

namespace slamd::core {

template <>
struct VariableTraits<Pose2> {
  static constexpr const char* kName = "Pose2";
  static constexpr int kDim = 3;
  static constexpr std::array<EntryKind, 3> kEntryKinds = {
      EntryKind::kTranslation, EntryKind::kTranslation, EntryKind::kRotation};
  static Pose2 Retract(const Pose2& x, const double* d) {
    return x.Retract(Eigen::Map<const Vector3>(d));
  }
  static Vector3 Local(const Pose2& a, const Pose2& b) { return a.LocalCoordinates(b); }
  static bool AllFinite(const Pose2& x) {
    return x.translation().allFinite() && std::isfinite(x.theta());
  }
  // (x, y, cos θ, sin θ): exact, where θ would be rounded through atan2.
  static constexpr int kEncodedSize = 4;
  static void Encode(const Pose2& x, double* out) {
    out[0] = x.x();
    out[1] = x.y();
    out[2] = x.rotation().c();
    out[3] = x.rotation().s();
  }
  static std::optional<Pose2> Decode(const double* in) {
    return Pose2(Rot2::FromCosSin(in[2], in[3]), Point2(in[0], in[1]));
  }
  static constexpr int kMessageSize = 3;
  static void EncodeMessage(const Pose2& x, double* out) {
    out[0] = x.x();
    out[1] = x.y();
    out[2] = x.theta();
  }
  static Matrix3 EstimateJacobian(const double* d) {
    // θ·P(δ+ε) seen from E = θ·P(δ): P(δ)⁻¹P(δ+ε) = (R(δ_θ)ᵀ ε_xy, ε_θ), exactly linear.
    const double c = std::cos(d[2]), s = std::sin(d[2]);
    Matrix3 J = Matrix3::Identity();
    J(0, 0) = c;
    J(0, 1) = s;
    J(1, 0) = -s;
    J(1, 1) = c;
    return J;
  }
  static constexpr bool kPlotted = true;
  static Vector2 PlanarPosition(const Pose2& x) { return x.translation(); }
  static Matrix2 PlanarCovariance(const Pose2& x, const Eigen::MatrixXd& cov) {
    const Matrix2 R = x.rotation().matrix();
    return R * cov.topLeftCorner<2, 2>() * R.transpose();
  }
};

template <>
struct VariableTraits<Pose3> {
  static constexpr const char* kName = "Pose3";
  static constexpr int kDim = 6;
  static constexpr std::array<EntryKind, 6> kEntryKinds = {
      EntryKind::kTranslation, EntryKind::kTranslation, EntryKind::kTranslation,
      EntryKind::kRotation,    EntryKind::kRotation,    EntryKind::kRotation};
  static Pose3 Retract(const Pose3& x, const double* d) {
    return x.Retract(Eigen::Map<const Vector6>(d));
  }
  static Vector6 Local(const Pose3& a, const Pose3& b) { return a.LocalCoordinates(b); }
  static bool AllFinite(const Pose3& x) {
    return x.translation().allFinite() && x.rotation().matrix().allFinite();
  }
  // (t, R row by row).
  static constexpr int kEncodedSize = 12;
  static void Encode(const Pose3& x, double* out) {
    for (int i = 0; i < 3; ++i) out[i] = x.translation()[i];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out[3 + 3 * r + c] = x.rotation().matrix()(r, c);
    }
  }
  static std::optional<Pose3> Decode(const double* in) {
    Matrix3 R;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R(r, c) = in[3 + 3 * r + c];
    }
    return Pose3(Rot3(R), Point3(in[0], in[1], in[2]));
  }
  static constexpr int kMessageSize = 7;
  static void EncodeMessage(const Pose3& x, double* out) {
    const Eigen::Quaterniond q = x.rotation().ToQuaternion();  // qw >= 0
    for (int i = 0; i < 3; ++i) out[i] = x.translation()[i];
    out[3] = q.w();
    out[4] = q.x();
    out[5] = q.y();
    out[6] = q.z();
  }
  static Matrix6 EstimateJacobian(const double* d) {
    // Log(Exp(δ)⁻¹ Exp(δ+ε)) = Jr(δ) ε + O(ε²).
    Matrix6 H;
    (void)Pose3::Exp(Eigen::Map<const Vector6>(d), &H);
    return H;
  }
  static constexpr bool kPlotted = true;
  static Vector2 PlanarPosition(const Pose3& x) { return x.translation().head<2>(); }
  static Matrix2 PlanarCovariance(const Pose3& x, const Eigen::MatrixXd& cov) {
    const Matrix3& R = x.rotation().matrix();
    const Matrix3 world = R * cov.topLeftCorner<3, 3>() * R.transpose();
    return world.topLeftCorner<2, 2>();
  }
};

}  // namespace slamd::core
