// Field-level checks shared by the per-message validators (validation.cc). Internal.
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

}  // namespace slamd::server::internal
