#pragma once

// The angle below which the geometry's closed-form coefficients (sin t / t, (1 - cos t) / t², ...)
// cancel catastrophically and their Taylor series is used instead: at 1e-2 the series'
// truncation error is below 1e-20. One value for Rot3, Pose2 and Pose3.
namespace slamd::core {

inline constexpr double kSmallAngle = 1e-2;

}  // namespace slamd::core
