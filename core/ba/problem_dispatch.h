// Internal to core/ba: turns a reconstruction's calibration model (a std::variant alternative)
// and whether its calibrations are refined into the template arguments of BaProblem, once per
// call, so that the per-observation code is compiled for each model with fixed sizes.
#pragma once

#include <algorithm>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "core/ba/bundle_adjuster_params.h"
#include "core/base/status.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core::internal {

// Ok when `r` can be adjusted: valid, with observations, one calibration model throughout.
inline Status CheckAdjustable(const Reconstruction& r, const char* what) {
  if (Status s = r.Validate(); !s.ok()) return s;
  if (r.observations.empty()) {
    return InvalidArgument(std::string(what) + ": the reconstruction has no observation");
  }
  const size_t model = r.intrinsics.front().calibration.index();
  for (size_t k = 0; k < r.intrinsics.size(); ++k) {
    if (r.intrinsics[k].calibration.index() != model) {
      return InvalidArgument(std::string(what) + ": intrinsics " + std::to_string(k) +
                             " have another calibration model than intrinsics 0 (one model per "
                             "reconstruction)");
    }
  }
  return Status::Ok();
}

// Calls fn.template operator()<Cal, kRefineCal>() for r's model; calibrations are refined when
// params ask for it and each intrinsics belongs to one image. r must pass CheckAdjustable.
template <typename Fn>
auto WithProblemType(const BundleAdjusterParams& params, const Reconstruction& r, Fn&& fn) {
  std::vector<int> users(r.intrinsics.size(), 0);
  for (const SfmImage& image : r.images) ++users[image.intrinsics];
  const bool refine = params.refine_intrinsics &&
                      std::all_of(users.begin(), users.end(), [](int u) { return u <= 1; });
  return std::visit(
      [&](const auto& calibration) {
        using Cal = std::decay_t<decltype(calibration)>;
        return refine ? fn.template operator()<Cal, true>() : fn.template operator()<Cal, false>();
      },
      r.intrinsics.front().calibration);
}

}  // namespace slamd::core::internal
