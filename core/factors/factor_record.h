// FactorRecord: a factor as plain data, what snapshots and exports store and the registry
// (factor_registry.h) rebuilds a factor from. Its type name says how to read the rest.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/base/key.h"
#include "core/factors/robust_kernel.h"
#include "core/variables/variable.h"

namespace slamd::core {

struct FactorRecord {
  std::string type;  // the registered type name, e.g. "BetweenPose2"
  KeyVector keys;
  std::vector<double> measured;      // Factor::EncodeMeasured's layout for the type
  Eigen::MatrixXd sqrt_information;  // the noise model's R
  RobustKernel robust;
  std::vector<Variable> values;  // values the factor carries (Factor::CarriedValues)
};

}  // namespace slamd::core
