// A reconstruction as a general factor graph: one Pose3 per image, one Point3 per point, one
// calibration variable per intrinsics (when refined) and one projection factor per observation,
// so the batch solver (core/batch) and iSAM2 optimise the same problem the bundle adjuster does.
// With unit pixel noise the graph's cost is twice the adjuster's (the batch solver's cost has no
// ½): at every estimate graph.Cost(values) = 2·(½ Σ ρ(|r|²)).
//
// Keys: image i → MakeKey('x', i), point j → MakeKey('l', j), intrinsics k → MakeKey('k', k).
// Shared intrinsics (COLMAP cameras used by several images) are one variable. A calibration
// variable refines every parameter, so a calibration whose model cannot write all of them back
// (COLMAP's PINHOLE, SIMPLE_PINHOLE, OPENCV: no skew; SIMPLE_RADIAL: no k2; CalibrationBasis) is
// held at its value here; the bundle adjuster refines what such models can hold.
#pragma once

#include <optional>
#include <vector>

#include "core/base/status.h"
#include "core/factors/factor_graph.h"
#include "core/factors/noise_model.h"
#include "core/factors/robust_kernel.h"
#include "core/factors/values.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core {

struct ReconstructionGraphParams {
  // Calibrations as variables (SelfCalibratingProjectionFactor) or held at the file's values
  // (ProjectionFactor).
  bool refine_intrinsics = true;
  // Pixel noise σ of every observation. > 0.
  double pixel_sigma = 1.0;
  // On every observation, in whitened units (pixels when pixel_sigma = 1).
  RobustKernel robust = {};

  Status Validate() const;
};

struct ReconstructionGraph {
  FactorGraph graph;
  Values values;
  std::vector<Key> images;        // images[i]: image i's pose T_wc
  std::vector<Key> points;        // points[j]: point j
  // calibrations[k]: intrinsics k's variable, none when held (all empty when none is refined).
  std::vector<std::optional<Key>> calibrations;
};

// The keys of `r`'s unknowns, calibrations only when refined and their model can hold every
// parameter (graph and values left empty).
ReconstructionGraph ReconstructionKeys(const Reconstruction& r, bool refine_intrinsics);
// Intrinsics k's calibration as a variable.
Variable CalibrationVariable(const SfmIntrinsics& intrinsics);
// Adds observation `o` of `r` to `graph` on `keys`' variables: a SelfCalibratingProjectionFactor
// when `keys` has its calibration, else a ProjectionFactor with the calibration fixed.
void AddObservationFactor(const Reconstruction& r, const SfmObservation& o,
                          const ReconstructionGraph& keys, const NoiseModel& noise,
                          const RobustKernel& robust, FactorGraph* graph);

// Fails with kInvalidArgument on invalid params or reconstruction (Reconstruction::Validate).
Result<ReconstructionGraph> BuildReconstructionGraph(const Reconstruction& reconstruction,
                                                     const ReconstructionGraphParams& params = {});

// Writes `values` (an estimate of built.values' keys) back into the poses, points and, when
// refined, calibrations of `reconstruction` (the one the graph was built from).
void UpdateReconstruction(const ReconstructionGraph& built, const Values& values,
                          Reconstruction* reconstruction);

}  // namespace slamd::core
