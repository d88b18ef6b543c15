#include "core/isam/isam2_params.h"

#include "core/base/param_check.h"

namespace slamd::core {

Status Isam2Params::Validate() const {
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.rotation_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.translation_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.error_threshold, >=, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.skip, >=, 1);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.max_variables, >=, 0);
  SLAMD_PARAM_CHECK(Isam2Params, wildfire_threshold, >=, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, refine_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, refine_max_variables, >=, 0);
  SLAMD_PARAM_CHECK(Isam2Params, threads, >=, 1);
  SLAMD_PARAM_CHECK(Isam2Params, batch_every, >=, 0);
  return elimination.Validate();
}

}  // namespace slamd::core
