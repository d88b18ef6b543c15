// A random value of every variable type (core/variables/variable_list.h), for tests that run
// over the whole list. Adding a variable type: a RandomValue for it here if the default (a
// parameter vector) does not fit.
#pragma once

#include <random>

#include "core/variables/variable.h"

namespace slamd::testing {

// A random value of each variable type: poses spread over rotations, points with entries in
// [-2, 2], calibrations with entries in [-2, 2] but a first parameter (a focal length) of
// 300-700 pixels.
template <typename T>
T RandomValue(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  typename T::Vector v;
  for (int i = 0; i < v.size(); ++i) v[i] = u(rng);
  v[0] = 500.0 + 100.0 * v[0];
  return T(v);
}
template <>
inline core::Pose2 RandomValue<core::Pose2>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  return core::Pose2(u(rng), u(rng), u(rng));
}
template <>
inline core::Pose3 RandomValue<core::Pose3>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  return core::Pose3(core::Rot3::Exp(core::Vector3(u(rng), u(rng), u(rng)) * 0.7),
                     core::Point3(u(rng), u(rng), u(rng)));
}
template <>
inline core::Point2 RandomValue<core::Point2>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  return core::Point2(u(rng), u(rng));
}
template <>
inline core::Point3 RandomValue<core::Point3>(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  return core::Point3(u(rng), u(rng), u(rng));
}

}  // namespace slamd::testing
