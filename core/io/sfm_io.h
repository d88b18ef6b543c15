// Reconstructions (core/sfm/reconstruction.h) read from and written to the common structure-
// from-motion formats: BAL problems. Every reader converts to the Reconstruction's conventions
// (poses T_wc, camera looking down +z with y down, pixels in the calibration's frame) and every
// writer converts back.
//
// BAL (Bundle Adjustment in the Large, Agarwal et al. 2010), one file:
//   <num_cameras> <num_points> <num_observations>
//   <camera> <point> <x> <y>             num_observations times (indices from 0)
//   <w1 w2 w3 t1 t2 t3 f k1 k2>          num_cameras times (Rodrigues rotation vector, ...)
//   <X Y Z>                              num_points times
// The file is read as one stream of blank-separated numbers: they may spread over lines in any
// way (some BAL files put one number per line). BAL's camera: P = R·X + t, p = -P / P.z,
// pixel = f·(1 + k1|p|² + k2|p|⁴)·p, i.e. its camera looks down -z with y up. slamd's camera frame
// is BAL's rotated by π about x: with F = diag(1, -1, -1), R_cw = F·R, t_cw = F·t, the pose is
// T_wc = (R_cw, t_cw)⁻¹ and the observed pixel (x, y) becomes (x, -y), which leaves every
// reprojection error unchanged. Camera i becomes image i with its own intrinsics i: Cal3Bundler
// (f, k1, k2), principal point zero, model "", no size; ids are the indices; names are empty and
// points keep the default colour and error (BAL has neither).
//
// Errors of the readers (no exception, no abort, whatever the input):
//   kNotFound  the file does not exist;
//   kIoError   it cannot be read;
//   kDataLoss  any problem with the content, as "FILE:LINE: expected ..., got '...'": a
//              non-number, NaN/inf/overflow, an index out of range, a truncated file or numbers
//              after the last point.
// Writers: numbers in the shortest form that reads back to the same double, so a write→read
// round trip reproduces everything the format stores exactly, except for the rotations
// (Rodrigues vector ↔ matrix, ~1e-15) and the translations derived through them. A writer formats
// everything before it writes, so a reconstruction it refuses (kInvalidArgument, naming what cannot
// be written) leaves no file; kIoError when the file cannot be written. Reconstruction::Validate()
// failures are kInvalidArgument too. Thread safety: the functions share no state; concurrent calls
// on different paths are safe.
#pragma once

#include <string>

#include "core/base/status.h"
#include "core/sfm/reconstruction.h"

namespace slamd::core {

// Reads a BAL problem (see the file comment).
Result<Reconstruction> ReadBal(const std::string& path);

// Writes `r` as a BAL problem: observations in the order of r.observations, one a line, then the
// 9 numbers of each image and the 3 of each point, one a line (the layout of Agarwal et al.'s
// files). BAL holds one Cal3Bundler camera per image, pixels centred: kInvalidArgument unless
// r.intrinsics.size() == r.images.size(), image i uses intrinsics i, and every intrinsics is a
// Cal3Bundler with a zero principal point. Names, ids, colours, errors, sizes and model names are
// not written (BAL has no place for them).
Status WriteBal(const Reconstruction& r, const std::string& path);

}  // namespace slamd::core
