#include "core/ba/reconstruction_graph.h"

#include <variant>

#include "core/base/param_check.h"
#include "core/factors/projection_factor.h"

namespace slamd::core {

Status ReconstructionGraphParams::Validate() const {
  SLAMD_PARAM_CHECK(ReconstructionGraphParams, pixel_sigma, >, 0.0);
  return Status::Ok();
}

Result<ReconstructionGraph> BuildReconstructionGraph(const Reconstruction& r,
                                                     const ReconstructionGraphParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  SLAMD_RETURN_IF_ERROR(r.Validate());
  Result<NoiseModel> noise = NoiseModel::Isotropic(2, params.pixel_sigma);
  if (!noise.ok()) return noise.status();

  ReconstructionGraph out;
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    out.images.push_back(MakeKey('x', i));
    SLAMD_RETURN_IF_ERROR(out.values.Insert(out.images.back(), r.images[i].pose));
  }
  for (std::size_t j = 0; j < r.points.size(); ++j) {
    out.points.push_back(MakeKey('l', j));
    SLAMD_RETURN_IF_ERROR(out.values.Insert(out.points.back(), r.points[j].position));
  }
  if (params.refine_intrinsics) {
    for (std::size_t k = 0; k < r.intrinsics.size(); ++k) {
      out.calibrations.push_back(MakeKey('k', k));
      const Variable calibration =
          std::visit([](const auto& K) { return Variable(K); }, r.intrinsics[k].calibration);
      SLAMD_RETURN_IF_ERROR(out.values.Insert(out.calibrations.back(), calibration));
    }
  }
  for (const SfmObservation& o : r.observations) {
    const Key pose = out.images[o.image];
    const Key point = out.points[o.point];
    const int k = r.images[o.image].intrinsics;
    std::visit(
        [&](const auto& K) {
          using Cal = std::decay_t<decltype(K)>;
          if (params.refine_intrinsics) {
            out.graph.Emplace<SelfCalibratingProjectionFactor<Cal>>(
                pose, point, out.calibrations[k], o.uv, *noise, params.robust);
          } else {
            out.graph.Emplace<ProjectionFactor<Cal>>(pose, point, o.uv, K, *noise, params.robust);
          }
        },
        r.intrinsics[k].calibration);
  }
  return out;
}

void UpdateReconstruction(const ReconstructionGraph& built, const Values& values,
                          Reconstruction* r) {
  for (std::size_t i = 0; i < built.images.size(); ++i) {
    r->images[i].pose = values.At<Pose3>(built.images[i]);
  }
  for (std::size_t j = 0; j < built.points.size(); ++j) {
    r->points[j].position = values.At<Point3>(built.points[j]);
  }
  for (std::size_t k = 0; k < built.calibrations.size(); ++k) {
    std::visit([&](auto& K) { K = values.At<std::decay_t<decltype(K)>>(built.calibrations[k]); },
               r->intrinsics[k].calibration);
  }
}

}  // namespace slamd::core
