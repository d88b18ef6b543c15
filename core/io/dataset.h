// Datasets: pose graphs and landmark SLAM problems read from the common text formats (g2o,
// TORO, iSAM) into a FactorGraph plus an initial guess, and written back as g2o.
//
// Keys: pose id i becomes MakeKey('x', i) and landmark id j becomes MakeKey('l', j). Ids are
// kept as in the file (not renumbered; victoriaPark.txt's pose ids are not contiguous). Pose and
// landmark ids are separate namespaces: the line type says which one an id belongs to.
//
// Formats (one line per record; blank lines and lines starting with '#' are skipped; fields
// are separated by spaces or tabs; a trailing '\r' is ignored):
//   g2o 2D  VERTEX_SE2 id x y θ
//           EDGE_SE2 i j dx dy dθ  I11 I12 I13 I22 I23 I33   (information, upper triangle,
//                                                           (x, y, θ) order)
//           VERTEX_XY id x y
//           EDGE_SE2_XY i j dx dy  I11 I12 I22               (pose i sees landmark j at (dx, dy)
//                                                           in its frame: RelativePointFactor)
//   g2o 3D  VERTEX_SE3:QUAT id x y z qx qy qz qw             (quaternion with w LAST)
//           EDGE_SE3:QUAT i j dx dy dz qx qy qz qw + 21      (information, upper triangle of
//                                                           6x6 in (t, R) order = slamd's
//                                                           Pose3 tangent order: no reordering)
//   g2o     FIX id                                          (recorded in Dataset::fixed only)
//   TORO    VERTEX2 id x y θ
//           EDGE2 i j dx dy dθ  I_xx I_xy I_yy I_θθ I_xθ I_yθ   (information, TORO's order!)
//           EQUIV i j   "the same node": read as a BetweenFactor<Pose2>(x_i, x_j, identity) with
//                       unit information (R = I), i.e. a soft equality of weight 1, because
//                       merging the two variables would change the graph's keys. Counted in
//                       Dataset::num_equivalences, not in num_pose_edges.
//   iSAM    ODOMETRY | EDGE2  i j dx dy dθ  s11 s12 s13 s22 s23 s33
//           LANDMARK pose lm dx dy  s11 s12 s22         (RelativePointFactor<Pose2, Point2>)
//           EDGE3 i j x y z roll pitch yaw [+ 21]       (3D; see below)
//           The noise numbers are the upper-triangular SQUARE-ROOT information R, row-first,
//           Ω = RᵀR (iSAM data/README), unless ReadOptions::isam_noise says they are an upper-
//           triangular covariance (GTSAM's victoria_park.txt).
//           EDGE3 follows iSAM's Loader: R = Rz(yaw)·Ry(pitch)·Rx(roll); the optional 21 numbers
//           are a sqrt-information of iSAM's own error, the difference of (x, y, z, yaw, pitch,
//           roll) vectors (with the rotation block read as iSAM reads it; identity when absent).
//           It is converted to first order at the measurement into slamd's BetweenFactor<Pose3>
//           chart (the SE(3) log, (t, R) order); an edge near gimbal lock (|pitch| ≈ π/2) is an
//           error.
//
// Format detection (ReadOptions::format == kAuto) looks at the first decisive tag, whatever the
// file name: a g2o tag means g2o (GTSAM's pose2example.txt is g2o); VERTEX2 or EQUIV means TORO;
// ODOMETRY or LANDMARK means iSAM; EDGE3 means iSAM (TORO 3D in a *.graph file: unsupported).
// EDGE2 is ambiguous (TORO and iSAM both use it, with different noise conventions): it decides
// TORO in a file named *.graph; elsewhere a later decisive tag decides, and a file of EDGE2
// lines only is iSAM (manhattanOlson3500_groundtruth.txt).
//
// Initial guess (Dataset::initial):
//   1. Poses: the file's vertices, when present. Poses without a vertex (manhattan.g2o and all
//      iSAM files have none) are composed along the pose-pose edges, with the result of repeated
//      passes over the edges in file order: if x_i is known and x_j not, x_j = x_i ∘ z; if x_j
//      is known and x_i not, x_i = x_j ∘ z⁻¹, starting from the poses with a vertex. If the
//      lowest pose id is still unknown after that (always so when no pose has a vertex), it
//      starts at the identity and the passes continue from it. Poses still unknown then are an
//      error. (The passes are computed exactly, in O(E log E) rather than O(E·V).)
//      With ReadOptions::compose_initial_from_odometry, all vertices are ignored except the
//      lowest pose id's (identity when it has none), and everything is composed from there.
//   2. Landmarks: the file's vertex when present (and not compose_initial_from_odometry),
//      otherwise pose.TransformFrom(measured) of the landmark's first observation in the file.
//
// Errors (no exception, no abort, whatever the input):
//   kNotFound  the file does not exist;   kIoError  it cannot be read / written.
//   kDataLoss  any problem with the content, as "FILE:LINE: expected ..., got '...'": a wrong
//              number of fields, a non-number, NaN/inf/overflow, a negative or too large id
//              (> 2^48-1), an unknown tag (or one of another format), an edge from a pose to
//              itself, a duplicate vertex, a 2D line in a 3D file, an invalid noise matrix (not
//              positive definite, ill-conditioned; the NoiseModel message is included), a zero
//              quaternion; "FILE: ..." for a pose no edge chain reaches from a known pose.
// Edges may refer to ids that have no vertex line (see "Initial guess").
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/base/key.h"
#include "core/base/status.h"
#include "core/factors/factor_graph.h"
#include "core/factors/values.h"

namespace slamd::core {

enum class DatasetFormat { kAuto, kG2o, kToro, kIsam };
const char* DatasetFormatName(DatasetFormat format);

struct ReadOptions {
  // Which reader to use. kAuto detects it from the tags and the file name (see the file
  // comment); any other value forces that format, and tags of other formats are then errors.
  DatasetFormat format = DatasetFormat::kAuto;

  // How to read the noise numbers of iSAM lines (ODOMETRY, EDGE2 in iSAM files, LANDMARK).
  enum class IsamNoise {
    kSqrtInformation,  // upper-triangular square-root information R, Ω = RᵀR (iSAM's own files)
    kCovariance,       // upper triangle of the covariance Σ (GTSAM's victoria_park.txt)
  };
  IsamNoise isam_noise = IsamNoise::kSqrtInformation;

  // When true, the file's vertices are ignored for the initial guess (all but the lowest pose
  // id's, which anchors the trajectory): poses are composed along the edges and landmarks set
  // from their first observation. Default false: use the vertices when present.
  bool compose_initial_from_odometry = false;
};

struct Dataset {
  std::string path;                             // the file read (or to be written)
  DatasetFormat format = DatasetFormat::kAuto;  // the format actually read
  bool is_3d = false;                           // Pose3 poses (else Pose2 / Point2)
  FactorGraph graph;  // every factor in file order; no prior (the gauge is the caller's choice)
  Values initial;     // every pose (ascending id), then every landmark (ascending id)
  std::vector<Key> poses;      // pose keys, ascending id
  std::vector<Key> landmarks;  // landmark keys, ascending id
  std::vector<Key> fixed;      // poses named by g2o FIX lines (no factor is added for them)

  std::size_t num_pose_edges = 0;             // pose-pose factors from edge lines (no EQUIV)
  std::size_t num_equivalences = 0;           // TORO EQUIV lines (also BetweenFactors in graph)
  std::size_t num_landmark_observations = 0;  // pose-landmark factors
  std::size_t num_loop_like = 0;              // pose edges with |i − j| ≠ 1 (a heuristic)
};

// Reads a dataset (see the file comment for formats, conventions and errors).
Result<Dataset> ReadDataset(const std::string& path, const ReadOptions& options = {});

// Writes `dataset` as a g2o file: FIX lines, then a vertex for every key of dataset.poses and
// dataset.landmarks (values from dataset.initial), then one edge per factor in graph order, with
// the information RᵀR of its noise model. Numbers are written in the shortest form that reads
// back to the same double, so a write→read round trip reproduces vertices, measurements and
// information up to the rounding of angle↔(cos, sin), quaternion↔matrix and R↔RᵀR conversions
// (~1e-15 relative; the tests check 1e-12).
//   BetweenFactor<Pose2>                -> EDGE_SE2        BetweenFactor<Pose3> -> EDGE_SE3:QUAT
//   RelativePointFactor<Pose2, Point2>  -> EDGE_SE2_XY
// Errors: kInvalidArgument for a factor with no g2o form (the message names its index and type,
// e.g. "PriorPose2"), for keys that are not 'x'/'l' keys without a robot id, or for a pose or
// landmark missing from dataset.initial; kIoError when the file cannot be written. Robust
// kernels are not written (g2o files have no field for them). Note that other g2o tools share
// one id space between poses and landmarks; slamd does not, so colliding ids are written as is.
Status WriteG2o(const Dataset& dataset, const std::string& path);

// Writes `dataset` in the iSAM text format (2D only; iSAM files have no vertex lines, so
// dataset.initial is not written and ReadDataset composes the initial guess from the edges,
// starting at the identity for the lowest pose id). One line per factor in graph order, with the
// upper-triangular square-root information R of its noise model (Ω = RᵀR), numbers in the
// shortest form that reads back to the same double:
//   BetweenFactor<Pose2>                -> ODOMETRY i j dx dy dθ s11 s12 s13 s22 s23 s33
//   RelativePointFactor<Pose2, Point2>  -> LANDMARK pose lm dx dy s11 s12 s22
// ODOMETRY is used for every pose-pose edge, loop closures included (as in iSAM's
// manhattanOlson3500.txt), so that format detection reads the file as iSAM.
// Errors: kInvalidArgument for a factor with no iSAM form here (3D: EDGE3's Euler-angle noise is
// not written), for keys that are not 'x'/'l' keys without a robot id; kIoError when the file
// cannot be written (nothing is written then).
Status WriteIsam(const Dataset& dataset, const std::string& path);

}  // namespace slamd::core
