// Reconstruction: what structure from motion produces and bundle adjustment refines: images
// (camera poses) with their intrinsics, 3-D points, and the pixel where each image observed each
// point. The readers and writers of BAL, COLMAP's text model and PLY (core/io/sfm_io.h) fill and
// write it; the bundle adjuster (core/ba/bundle_adjuster.h) refines it in place.
//
// Conventions (one for every format; the readers convert):
//   * An image's pose is T_wc (Pose3: camera frame -> world frame, as every pose in slamd).
//   * The camera looks down its +z axis, image x to the right and y down (OpenCV, COLMAP).
//   * Pixels are what the calibration's projection gives (core/geometry/camera.h). Cal3Bundler
//     has no principal point: its pixels are measured from `SfmIntrinsics::principal_point`
//     (zero for BAL, whose pixels are already centred; COLMAP's cx, cy for SIMPLE_RADIAL and
//     RADIAL cameras), which the readers subtract and the writers add back.
// Indices (SfmImage::intrinsics, SfmObservation::image/point) are positions in the vectors here;
// the ids are the files' own (COLMAP CAMERA_ID, IMAGE_ID, POINT3D_ID), kept to write them back.
// A plain value: copyable, no invariants beyond what Validate checks.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "core/base/status.h"
#include "core/geometry/calibration.h"
#include "core/geometry/eigen_types.h"
#include "core/geometry/pose3.h"

namespace slamd::core {

// One camera's intrinsics (a COLMAP camera; one per image in BAL files).
struct SfmIntrinsics {
  Calibration calibration = Cal3Bundler();
  // Cal3Bundler only: the pixel origin of its projection in image pixels (see the file comment).
  Vector2 principal_point = Vector2::Zero();
  // COLMAP's model name as read ("PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV"), written back
  // as is; empty for BAL.
  std::string model = "";
  int width = 0, height = 0;  // image size in pixels; 0 when the file has none (BAL)
  std::uint32_t id = 0;       // COLMAP CAMERA_ID; BAL: the camera's index
};

// The calibration parameters that the intrinsics' model lets a bundle adjuster refine, as the
// change of each parameter per refined one (kDim x kDim; a zero column: a parameter held at its
// value). No model (BAL) or RADIAL: every parameter. COLMAP's models hold no skew (PINHOLE,
// OPENCV: the skew is held), SIMPLE_PINHOLE has one focal length (column fx moves fx and fy
// together; fy held) and SIMPLE_RADIAL no k2 (held), so that the result can be written back.
// The principal point (Cal3_S2, Cal3DS2) only with `principal_point`: shifting it is nearly the
// same as turning every camera, so it is poorly determined (COLMAP holds it by default too).
Eigen::MatrixXd CalibrationBasis(const SfmIntrinsics& k, bool principal_point);

// One image: where its camera was.
struct SfmImage {
  Pose3 pose;             // T_wc
  int intrinsics = 0;     // index into Reconstruction::intrinsics
  std::string name = "";  // COLMAP NAME; empty for BAL
  std::uint32_t id = 0;
};

struct SfmPoint {
  Point3 position = Point3::Zero();
  std::array<std::uint8_t, 3> color = {128, 128, 128};  // RGB (COLMAP, PLY)
  double error = -1.0;   // COLMAP's mean reprojection error in pixels; -1 when unknown
  std::uint64_t id = 0;  // COLMAP POINT3D_ID; BAL: the point's index
};

struct SfmObservation {
  int image = 0;                 // index into Reconstruction::images
  int point = 0;                 // index into Reconstruction::points
  Vector2 uv = Vector2::Zero();  // pixel, in the calibration's pixel frame (file comment)
};

struct Reconstruction {
  std::vector<SfmIntrinsics> intrinsics;
  std::vector<SfmImage> images;
  std::vector<SfmPoint> points;
  std::vector<SfmObservation> observations;

  // Ok when every index is in range and every number finite; otherwise kInvalidArgument naming
  // the first offending image / observation / point.
  Status Validate() const;
};

}  // namespace slamd::core
