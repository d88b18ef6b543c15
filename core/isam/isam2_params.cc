#include "core/isam/isam2_params.h"

#include "core/base/param_check.h"

namespace slamd::core {

Status Isam2Params::Validate() const {
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.rotation_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.translation_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.calibration_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.other_threshold, >, 0.0);
  for (const Relinearization::TypeThreshold& t : relinearization.per_type) {
    if (!VariableTypeFromName(t.type)) {
      return InvalidArgument("Isam2Params::relinearization.per_type: unknown variable type '" +
                             t.type + "'");
    }
    if (!(t.threshold > 0.0)) {
      return InvalidArgument("Isam2Params::relinearization.per_type[" + t.type +
                             "].threshold = " + std::to_string(t.threshold) + "; violates > 0");
    }
  }
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.error_threshold, >=, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.skip, >=, 1);
  SLAMD_PARAM_CHECK(Isam2Params, relinearization.max_variables, >=, 0);
  SLAMD_PARAM_CHECK(Isam2Params, wildfire_threshold, >=, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, refine_threshold, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, refine_max_variables, >=, 0);
  SLAMD_PARAM_CHECK(Isam2Params, trust_region.initial_radius, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, trust_region.min_radius, >, 0.0);
  SLAMD_PARAM_CHECK(Isam2Params, threads, >=, 1);
  SLAMD_PARAM_CHECK(Isam2Params, batch_every, >=, 0);
  SLAMD_PARAM_CHECK(Isam2Params, max_landmarks_last, >=, 0);
  return elimination.Validate();
}

double Isam2Params::Relinearization::ThresholdOf(VariableType type, EntryKind kind) const {
  for (const TypeThreshold& t : per_type) {
    if (t.kind == kind && t.type == VariableTypeName(type)) return t.threshold;
  }
  switch (kind) {
    case EntryKind::kTranslation:
      return translation_threshold;
    case EntryKind::kRotation:
      return rotation_threshold;
    case EntryKind::kCalibration:
      return calibration_threshold;
    case EntryKind::kOther:
      return other_threshold;
  }
  return other_threshold;
}

}  // namespace slamd::core
