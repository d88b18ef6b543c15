#include "server/ingest/validation.h"

namespace slamd::server {

core::Status Limits::Validate() const {
  auto violates = [](const char* field, const std::string& value, const char* constraint) {
    return core::InvalidArgument(std::string("Limits::") + field + " = " + value + "; violates " +
                                 constraint);
  };
  if (max_robot_name_length < 1)
    return violates("max_robot_name_length", std::to_string(max_robot_name_length), ">= 1");
  if (max_client_name_length < 1)
    return violates("max_client_name_length", std::to_string(max_client_name_length), ">= 1");
  if (max_robust_kernel_name_length < 1) {
    return violates("max_robust_kernel_name_length", std::to_string(max_robust_kernel_name_length),
                    ">= 1");
  }
  if (max_query_keys < 1) return violates("max_query_keys", std::to_string(max_query_keys), ">= 1");
  if (max_joint_marginal_keys < 1) {
    return violates("max_joint_marginal_keys", std::to_string(max_joint_marginal_keys), ">= 1");
  }
  if (!(max_condition_number > 1.0 &&
        max_condition_number <= core::NoiseModel::kMaxConditionNumber)) {
    return violates("max_condition_number", std::to_string(max_condition_number), "in (1, 1e14]");
  }
  if (!(quaternion_norm_tolerance > 0.0 && quaternion_norm_tolerance <= 0.1)) {
    return violates("quaternion_norm_tolerance", std::to_string(quaternion_norm_tolerance),
                    "in (0, 0.1]");
  }
  if (!(symmetry_tolerance >= 0.0 && symmetry_tolerance <= 1e-3)) {
    return violates("symmetry_tolerance", std::to_string(symmetry_tolerance), "in [0, 1e-3]");
  }
  if (!(min_variance > 0.0)) {
    return violates("min_variance", std::to_string(min_variance), "> 0");
  }
  if (!(max_abs_value > 0.0)) {
    return violates("max_abs_value", std::to_string(max_abs_value), "> 0");
  }
  return core::Status::Ok();
}

}  // namespace slamd::server
