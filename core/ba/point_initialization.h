// Starting positions for points that have none worth the name: a reconstruction's file may
// place some points far from where their cameras see them (at the origin, behind the cameras,
// or from a stale model), and Levenberg-Marquardt then starts each in a poor basin. A point is
// "poor" when its RMS reprojection error exceeds `poor_rms_px` or it lies at or behind more
// than half of the cameras that observe it; a poor point is triangulated again from its
// observations with the cameras as they are (triangulation.h), and the new position is kept
// when its RMS reprojection error is lower. Points that cannot be triangulated (too little
// parallax, fewer than 2 views) keep their position.
#pragma once

#include "core/base/status.h"
#include "core/sfm/reconstruction.h"
#include "core/sfm/triangulation.h"

namespace slamd::core {

struct PointInitializationReport {
  int poor = 0;      // points found poor
  int replaced = 0;  // of those, moved to their triangulation
};

// `poor_rms_px` > 0. `params` are the triangulation's (its max_reprojection_px also bounds what
// replaces a point). kInvalidArgument for an invalid reconstruction or params, or one that
// BundleAdjust refuses (no observation, several calibration models).
Result<PointInitializationReport> RetriangulatePoorPoints(Reconstruction* reconstruction,
                                                          double poor_rms_px = 100.0,
                                                          const TriangulationParams& params = {
                                                              .max_reprojection_px = 1e9});

}  // namespace slamd::core
