// Conversion of inbound LCM messages into core types (each type's Convert and ToLcm are in its
// spec, server/messages/<type>.h): validate, then build the measurement and its NoiseModel. The
// one call a handler makes per message:
//
//   Checked<OdometryMeasurement> odo = Convert(msg, limits);
//   if (!odo.ok()) { publish a reject_t from odo.verdict(); return; }
//   ... journal, queue odo.value() ...
//
// Poses: 2D values (x, y, theta) -> Pose2(x, y, theta); 3D (x, y, z, qw, qx, qy, qz) ->
// Pose3(Rot3::FromQuaternion (normalised), (x, y, z)). Covariances -> NoiseModel::FromCovariance
// of the (symmetrised) row-major matrix, in the message's tangent order (slamd's).
// Thread-safe; never throws; a rejected message yields no value, only the Verdict.
#pragma once

#include <optional>
#include <utility>

#include "core/base/check.h"
#include "server/ingest/measurements.h"
#include "server/ingest/validation.h"

namespace slamd::server {

// Either a converted value or the Verdict that rejected the message.
template <typename T>
class [[nodiscard]] Checked {
 public:
  Checked(T value) : value_(std::move(value)) {}  // NOLINT: implicit, so `return value;` works
  Checked(Verdict verdict) : verdict_(std::move(verdict)) {  // NOLINT
    SLAMD_CHECK(!verdict_.ok()) << "a Checked built from a Verdict must carry a rejection";
  }

  bool ok() const { return value_.has_value(); }
  const Verdict& verdict() const { return verdict_; }
  const T& value() const& {
    SLAMD_CHECK(ok()) << "value() of a rejected message: " << verdict_.message;
    return *value_;
  }
  T&& value() && {
    SLAMD_CHECK(ok()) << "value() of a rejected message: " << verdict_.message;
    return std::move(*value_);
  }

 private:
  std::optional<T> value_;
  Verdict verdict_;
};

}  // namespace slamd::server
