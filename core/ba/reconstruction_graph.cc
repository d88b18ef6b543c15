#include "core/ba/reconstruction_graph.h"

#include <variant>

#include "core/base/param_check.h"
#include "core/factors/projection_factor.h"

namespace slamd::core {

Status ReconstructionGraphParams::Validate() const {
  SLAMD_PARAM_CHECK(ReconstructionGraphParams, pixel_sigma, >, 0.0);
  return Status::Ok();
}

ReconstructionGraph ReconstructionKeys(const Reconstruction& r, bool refine_intrinsics) {
  ReconstructionGraph keys;
  for (std::size_t i = 0; i < r.images.size(); ++i) keys.images.push_back(MakeKey('x', i));
  for (std::size_t j = 0; j < r.points.size(); ++j) keys.points.push_back(MakeKey('l', j));
  if (refine_intrinsics) {
    for (std::size_t k = 0; k < r.intrinsics.size(); ++k) {
      const bool every_parameter = CalibrationBasis(r.intrinsics[k], true).isIdentity();
      keys.calibrations.push_back(every_parameter ? std::optional(MakeKey('k', k)) : std::nullopt);
    }
  }
  return keys;
}

Variable CalibrationVariable(const SfmIntrinsics& intrinsics) {
  return std::visit([](const auto& K) { return Variable(K); }, intrinsics.calibration);
}

void AddObservationFactor(const Reconstruction& r, const SfmObservation& o,
                          const ReconstructionGraph& keys, const NoiseModel& noise,
                          const RobustKernel& robust, FactorGraph* graph) {
  const Key pose = keys.images[o.image];
  const Key point = keys.points[o.point];
  const int k = r.images[o.image].intrinsics;
  std::visit(
      [&](const auto& K) {
        using Cal = std::decay_t<decltype(K)>;
        if (!keys.calibrations.empty() && keys.calibrations[k]) {
          graph->Emplace<SelfCalibratingProjectionFactor<Cal>>(pose, point, *keys.calibrations[k],
                                                               o.uv, noise, robust);
        } else {
          graph->Emplace<ProjectionFactor<Cal>>(pose, point, o.uv, K, noise, robust);
        }
      },
      r.intrinsics[k].calibration);
}

Result<ReconstructionGraph> BuildReconstructionGraph(const Reconstruction& r,
                                                     const ReconstructionGraphParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  SLAMD_RETURN_IF_ERROR(r.Validate());
  Result<NoiseModel> noise = NoiseModel::Isotropic(2, params.pixel_sigma);
  if (!noise.ok()) return noise.status();

  ReconstructionGraph out = ReconstructionKeys(r, params.refine_intrinsics);
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    SLAMD_RETURN_IF_ERROR(out.values.Insert(out.images[i], r.images[i].pose));
  }
  for (std::size_t j = 0; j < r.points.size(); ++j) {
    SLAMD_RETURN_IF_ERROR(out.values.Insert(out.points[j], r.points[j].position));
  }
  for (std::size_t k = 0; k < out.calibrations.size(); ++k) {
    if (!out.calibrations[k]) continue;
    SLAMD_RETURN_IF_ERROR(
        out.values.Insert(*out.calibrations[k], CalibrationVariable(r.intrinsics[k])));
  }
  for (const SfmObservation& o : r.observations) {
    AddObservationFactor(r, o, out, *noise, params.robust, &out.graph);
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
    if (!built.calibrations[k]) continue;
    std::visit([&](auto& K) { K = values.At<std::decay_t<decltype(K)>>(*built.calibrations[k]); },
               r->intrinsics[k].calibration);
  }
}

}  // namespace slamd::core
