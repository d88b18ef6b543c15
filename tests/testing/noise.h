// Test helper: Noise(dim, sigma), the isotropic noise model of `dim` rows and standard deviation
// `sigma` (which the tests choose valid).
#pragma once

#include "core/factors/noise_model.h"

namespace slamd::testing {

inline core::NoiseModel Noise(int dim, double sigma) {
  return core::NoiseModel::Isotropic(dim, sigma).value();
}

}  // namespace slamd::testing
