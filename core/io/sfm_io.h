// Reconstructions (core/sfm/reconstruction.h) read from and written to the common structure-
// from-motion formats: BAL problems, COLMAP's text model, and PLY point clouds for viewing.
// Every reader converts to the Reconstruction's conventions (poses T_wc, camera looking down +z
// with y down, pixels in the calibration's frame) and every writer converts back.
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
// COLMAP text model (https://colmap.github.io/format.html), a directory of three files; blank
// lines and lines starting with '#' are skipped (except as an image's second line):
//   cameras.txt   CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
//   images.txt    IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME       (then, on the next line:)
//                 X Y POINT3D_ID  X Y POINT3D_ID  ...                 (may be empty)
//   points3D.txt  POINT3D_ID X Y Z R G B ERROR  IMAGE_ID POINT2D_IDX  IMAGE_ID POINT2D_IDX ...
// The quaternion and translation are world-to-camera (R_cw, t_cw; T_wc is their inverse). The
// camera convention is slamd's; pixels are COLMAP's (origin at the top-left corner of the image,
// pixel centres at 0.5) and are kept as in the file, like the principal point. Models:
//   SIMPLE_PINHOLE f cx cy                  -> Cal3_S2(f, f, 0, cx, cy)
//   PINHOLE        fx fy cx cy              -> Cal3_S2(fx, fy, 0, cx, cy)
//   SIMPLE_RADIAL  f cx cy k                -> Cal3Bundler(f, k, 0), principal point (cx, cy)
//   RADIAL         f cx cy k1 k2            -> Cal3Bundler(f, k1, k2), principal point (cx, cy)
//   OPENCV         fx fy cx cy k1 k2 p1 p2  -> Cal3DS2(Cal3_S2(fx, fy, 0, cx, cy), k1, k2, p1, p2)
// For the two Cal3Bundler models the observations are stored relative to the principal point
// (pixel - (cx, cy), reconstruction.h). SfmIntrinsics::model keeps the name read. An image line
// with nine fields has an empty NAME (COLMAP writes an empty name so).
// Observations: one per 2D point with a POINT3D_ID other than -1, in images.txt order (image by
// image, 2D point by 2D point). 2D points with POINT3D_ID -1 (keypoints no point was made from)
// are not kept, so POINT2D_IDX is not either: the writer numbers an image's 2D points anew. Every
// 2D point that names a 3-D point must appear in that point's track, and every track element
// (IMAGE_ID, POINT2D_IDX) must name a 2D point that names the track's point.
// Ids: CAMERA_ID and IMAGE_ID in [0, 2^32-1], POINT3D_ID in [0, 2^64-2] (COLMAP's invalid id,
// 2^64-1, is written -1), each unique in its file.
//
// Errors of the readers (no exception, no abort, whatever the input):
//   kNotFound  the file (BAL) or directory or one of its three files (COLMAP) does not exist;
//   kIoError   it cannot be read;
//   kDataLoss  any problem with the content, as "FILE:LINE: expected ..., got '...'" or
//              "FILE:LINE: <problem>": a wrong number of fields, a non-number, NaN/inf/overflow,
//              an index or id out of range, a truncated file or numbers after the last point
//              (BAL), an unknown camera model (named), an unknown camera/image/point id, a
//              duplicate id, an image's second line missing, a zero quaternion, a track that
//              disagrees with images.txt (both lines named).
// Writers: numbers in the shortest form that reads back to the same double, so a write→read
// round trip reproduces everything the format stores exactly, except for the rotations
// (Rodrigues vector or quaternion ↔ matrix, ~1e-15), the translations derived through them, and,
// for the Cal3Bundler models of COLMAP, the pixels (one rounding of the principal-point shift,
// ~1e-13 px). A writer formats everything before it writes, so a reconstruction it refuses
// (kInvalidArgument, naming what cannot be written) leaves no file; kIoError when the file cannot
// be written. Reconstruction::Validate() failures are kInvalidArgument too.
// Thread safety: the functions share no state; concurrent calls on different paths are safe.
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

// Reads the COLMAP text model in directory `dir` (cameras.txt, images.txt, points3D.txt; see the
// file comment). Intrinsics, images and points are in file order.
Result<Reconstruction> ReadColmapText(const std::string& dir);

// Writes `r` as cameras.txt, images.txt and points3D.txt in `dir` (created if missing; existing
// files of those names are replaced). Each intrinsics is written with its model's parameter layout;
// an empty model (a BAL reconstruction's) is written as PINHOLE (Cal3_S2), OPENCV (Cal3DS2) or
// RADIAL (Cal3Bundler). Each image's 2D points are its observations, in the order of
// r.observations, and each point's track lists its observations in that order (so reading the
// model back gives the observations grouped by image: in their order when they were already). ERROR
// is the stored value (-1, COLMAP's "unknown", included). kInvalidArgument for what COLMAP cannot
// hold: a model that is not one of the five above or does not match the calibration's type, a
// non-zero skew, fx != fy for SIMPLE_PINHOLE, k2 != 0 for SIMPLE_RADIAL, a name with a blank in it,
// a duplicate id. The three files are written one after the other: an I/O failure may leave some of
// them written.
Status WriteColmapText(const Reconstruction& r, const std::string& dir);

// ReadColmapText for a directory, ReadBal for anything else (kNotFound when nothing is there).
Result<Reconstruction> ReadReconstruction(const std::string& path);

// Writes an ASCII PLY point cloud (MeshLab, Open3D, CloudCompare): one vertex per point, in its
// colour, then one per image at its camera centre (the translation of T_wc), in red (255, 0, 0).
// Vertex properties: double x, y, z; uchar red, green, blue. Observations and intrinsics are not
// written. kInvalidArgument when r.Validate() fails.
Status WritePly(const Reconstruction& r, const std::string& path);

}  // namespace slamd::core
