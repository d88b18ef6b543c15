// Field-level checks shared by the per-message validators (server/messages/<type>.cc). Internal.
//
// Each check takes the field's full name ("odometry_t.covariance") and returns a Verdict that is
// ok or names that field. Messages are formatted only on failure.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "server/ingest/validation.h"

// Returns the Verdict of `expr` from the enclosing function when it is a rejection.
#define SLAMD_RETURN_IF_REJECTED(expr)                \
  do {                                                \
    ::slamd::server::Verdict slamd_verdict_ = (expr); \
    if (!slamd_verdict_.ok()) return slamd_verdict_;  \
  } while (false)

namespace slamd::server::internal {

// `v` in the shortest usual form ("-0.2", "1e+13", "nan").
std::string FormatNumber(double v);

// A rejection of `field`: message "<field>: <detail>".
Verdict Reject(RejectReason reason, std::string_view field, std::string_view detail);

// utime >= 0.
Verdict CheckUtime(std::string_view field, std::int64_t utime);

// 1..max_length chars of [A-Za-z0-9_.-] (0 chars too when allow_empty).
Verdict CheckName(std::string_view field, const std::string& name, int max_length,
                  bool allow_empty = false);

// 0 <= index <= core::kMaxKeyIndex.
Verdict CheckIndex(std::string_view field, std::int64_t index);

// The count field `count` (named count_field) equals the vector's length `actual` and, when
// expected >= 0, equals `expected` (`what_needs_it` says why, e.g. "dimension 2").
Verdict CheckCount(std::string_view count_field, std::int32_t count, size_t actual, int expected,
                   std::string_view what_needs_it);

// Every element finite; names the first that is not ("odometry_t.values[2]: not finite (nan)").
Verdict CheckFinite(std::string_view field, std::span<const double> values);
// Every |element| <= max_abs (kBadMeasurement naming the first that is not).
Verdict CheckMagnitude(std::string_view field, std::span<const double> values, double max_abs);

// | |(w, x, y, z)| - 1 | <= tolerance. `field` names the four entries.
Verdict CheckUnitQuaternion(std::string_view field, double w, double x, double y, double z,
                            double tolerance);

// A dim x dim row-major covariance (size and finiteness already checked): symmetric within
// limits.symmetry_tolerance, positive definite, condition number <= limits.max_condition_number.
// On success *noise (if given) holds core::NoiseModel::FromCovariance of its symmetric part.
Verdict CheckCovariance(std::string_view field, std::span<const double> row_major, int dim,
                        const Limits& limits, std::optional<core::NoiseModel>* noise);

// "" / "none" or a kernel core::RobustKernel::ParseKind knows, with a parameter valid for it
// (ignored for none). *robust (if given) receives the kernel.
Verdict CheckRobustKernel(std::string_view name_field, std::string_view parameter_field,
                          const std::string& name, double parameter, const Limits& limits,
                          core::RobustKernel* robust);

// Full field names of a measurement's value/covariance arrays, as string literals (no
// formatting unless something is rejected).
struct MeasurementFields {
  const char* num_values;
  const char* values;
  const char* quaternion;
  const char* num_covariance;
  const char* covariance;
};
#define SLAMD_MEASUREMENT_FIELDS(type)                                                \
  ::slamd::server::internal::MeasurementFields {                                      \
    type ".num_values", type ".values", type ".values[3..6]", type ".num_covariance", \
        type ".covariance"                                                            \
  }

// How a kind lays out its values: count, covariance dimension, whether values[3..6] is a
// quaternion, and the phrase used in size messages ("dimension 2", "kind 1 (bearing-range 2D)").
struct Layout {
  int num_values;
  int cov_dim;
  bool has_quaternion;
  const char* what;
};
inline constexpr Layout kPose2Layout{3, 3, false, "dimension 2 (x, y, theta)"};
inline constexpr Layout kPose3Layout{7, 6, true, "dimension 3 (x, y, z, qw, qx, qy, qz)"};

// Counts, finiteness, quaternion and covariance of one measurement; `extra` (checked after the
// values are known finite and before the covariance) holds kind-specific rules.
template <typename Msg, typename Extra>
Verdict CheckMeasurement(const Msg& msg, const MeasurementFields& f, const Layout& layout,
                         const Limits& limits, std::optional<core::NoiseModel>* noise,
                         Extra extra) {
  SLAMD_RETURN_IF_REJECTED(
      CheckCount(f.num_values, msg.num_values, msg.values.size(), layout.num_values, layout.what));
  SLAMD_RETURN_IF_REJECTED(CheckCount(f.num_covariance, msg.num_covariance, msg.covariance.size(),
                                      layout.cov_dim * layout.cov_dim, layout.what));
  SLAMD_RETURN_IF_REJECTED(CheckFinite(f.values, msg.values));
  SLAMD_RETURN_IF_REJECTED(CheckFinite(f.covariance, msg.covariance));
  SLAMD_RETURN_IF_REJECTED(CheckMagnitude(f.values, msg.values, limits.max_abs_value));
  SLAMD_RETURN_IF_REJECTED(extra());
  if (layout.has_quaternion) {
    const auto& v = msg.values;
    SLAMD_RETURN_IF_REJECTED(CheckUnitQuaternion(f.quaternion, v[3], v[4], v[5], v[6],
                                                 limits.quaternion_norm_tolerance));
  }
  return CheckCovariance(f.covariance, msg.covariance, layout.cov_dim, limits, noise);
}

// Names a message's dimension field: 2 -> kPose2Layout, 3 -> kPose3Layout, else kBadKind.
Verdict CheckDimension(const char* field, std::int8_t dimension, const Layout** layout);
// kUnusedFieldSet unless the field a target does not use is empty / zero.
Verdict MustBeEmpty(const char* field, const std::string& value, const char* target);
Verdict MustBeZero(const char* field, std::int64_t value, const char* target);
// kBadKind unless lo <= kind <= hi; `names` lists the valid kinds.
Verdict CheckKindRange(const char* field, std::int8_t kind, int lo, int hi, const char* names);

inline constexpr const char* kLandmarkKinds =
    "1 (bearing-range 2D), 2 (relative point 2D), 3 (relative point 3D)";
inline constexpr const char* kPriorKinds =
    "1 (pose 2D), 2 (pose 3D), 3 (position 2D), 4 (position 3D)";

}  // namespace slamd::server::internal
