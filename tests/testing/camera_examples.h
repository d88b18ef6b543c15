// Realistic cameras for the tests of projections, projection factors and triangulation: random
// calibrations of each model, camera poses and points in front of a camera (fixed seeds by the
// caller).
#pragma once

#include <random>

#include "core/geometry/calibration.h"
#include "core/geometry/pose3.h"

namespace slamd::testing {

// Focal lengths near 500 px, a principal point near the centre of a 640 x 480 image, barrel
// distortion (k1 ~ -0.2, k2 ~ 0.05) and tangential terms ~1e-3.
template <typename Cal>
Cal RandomCalibration(std::mt19937& rng);
template <>
inline core::Cal3_S2 RandomCalibration<core::Cal3_S2>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double fx = 500.0 + 80.0 * u(rng);
  return core::Cal3_S2(fx, fx * (1.0 + 0.05 * u(rng)), u(rng), 320.0 + 20.0 * u(rng),
                       240.0 + 20.0 * u(rng));
}
template <>
inline core::Cal3DS2 RandomCalibration<core::Cal3DS2>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const core::Cal3_S2 pinhole = RandomCalibration<core::Cal3_S2>(rng);
  return core::Cal3DS2(pinhole, -0.2 + 0.05 * u(rng), 0.05 + 0.03 * u(rng), 1e-3 * u(rng),
                       1e-3 * u(rng));
}
template <>
inline core::Cal3Bundler RandomCalibration<core::Cal3Bundler>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return core::Cal3Bundler(500.0 + 80.0 * u(rng), -0.2 + 0.05 * u(rng), 0.05 + 0.03 * u(rng));
}

// Any orientation, a position within 5 m of the origin along each axis.
inline core::Pose3 RandomCameraPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return core::Pose3(core::Rot3::Exp(2.0 * core::Vector3(u(rng), u(rng), u(rng))),
                     core::Point3(5.0 * u(rng), 5.0 * u(rng), 5.0 * u(rng)));
}

// A camera at `eye` looking at `target` (its +z axis), image y pointing down the world's z
// (`target` must not lie straight above or below `eye`).
inline core::Pose3 LookAt(const core::Point3& eye, const core::Point3& target) {
  const core::Vector3 z = (target - eye).normalized();
  const core::Vector3 x = z.cross(core::Vector3::UnitZ()).normalized();
  core::Matrix3 R;
  R << x, z.cross(x), z;
  return core::Pose3(core::Rot3(R), eye);
}

// A camera-frame point 1-10 m ahead, inside a ~53° field of view (|x|, |y| <= z / 2).
inline core::Point3 RandomPointAhead(std::mt19937& rng) {
  std::uniform_real_distribution<double> depth(1.0, 10.0), u(-0.5, 0.5);
  const double z = depth(rng);
  return core::Point3(u(rng) * z, u(rng) * z, z);
}

}  // namespace slamd::testing
