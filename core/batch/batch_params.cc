#include "core/batch/batch_params.h"

namespace slamd::core {

Status BatchParams::Validate() const {
  SLAMD_PARAM_CHECK(BatchParams, max_iterations, >=, 1);
  SLAMD_PARAM_CHECK(BatchParams, relative_tolerance, >=, 0.0);
  SLAMD_PARAM_CHECK(BatchParams, absolute_tolerance, >=, 0.0);
  SLAMD_PARAM_CHECK(BatchParams, initial_lambda, >=, 0.0);
  SLAMD_PARAM_CHECK(BatchParams, lambda_floor, >, 0.0);
  SLAMD_PARAM_CHECK(BatchParams, max_lambda, >, initial_lambda);
  SLAMD_PARAM_CHECK(BatchParams, max_lambda, >, lambda_floor);
  SLAMD_PARAM_CHECK(BatchParams, verbosity, >=, 0);
  return Status::Ok();
}

}  // namespace slamd::core
