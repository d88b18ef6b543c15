// Synthetic structure-from-motion worlds with ground truth, for `slamctl sim camera-city` and
// `slamctl sim camera-object`, tests and benchmarks of the bundle adjuster: cameras, points on
// surfaces, and the pixels where each camera sees each point.
//
// Like sim_world.h, a world is generated from its params alone: the same params (seed included)
// give the same world, bit for bit (randomness from sim_rng.h).
//
// Worlds (metres and radians, world z up; camera conventions of core/sfm/reconstruction.h: T_wc
// poses, the camera looking down +z with image y down):
//   kCity    city blocks on a grid of pitch kCityBlock with streets kCityStreet wide; each block
//            holds one building, a box of random height 8..30 m, its four facades covered with
//            points in the building's colour. A camera 1.6 m above the street's centre line
//            moves kCityStep along the streets per image, choosing at each crossing straight on
//            (probability 1/2), left or right (1/4 each; back only when it must); image k looks
//            forward, 50° to the left or 50° to the right for k mod 3 = 0, 1, 2, pitched up 10°.
//            The streets driven are the lines of a G x G grid of blocks, G = max(2,
//            round(√(cameras / 40))), starting at its corner heading +x; a ring of buildings
//            around it gives every street facades on both sides. A camera sees a point when the
//            point's facade faces it, no building stands between them and it is at most
//            kCityMaxDepth away along the optical axis.
//   kObject  an ellipsoid (semi-axes 1.0, 0.8 and 0.6 m along x, y, z) resting on the ground at
//            the origin, points uniform in direction on its surface, coloured by their normal.
//            Cameras on R = max(1, round(√(cameras / 4))) rings of a hemisphere of radius 4 m
//            around its centre, ring i at elevation 10° + 50°·(i + ½)/R, the cameras of a ring
//            evenly spaced in azimuth (odd rings offset by half a step), each looking at the
//            centre with image x horizontal. A camera sees a point when the surface faces it
//            (the object is convex: nothing else can hide the point).
// An observation exists where the camera sees the point, the point is in front of the camera
// and its true pixel lies inside the image, [0, width) x [0, height) (COLMAP's pixel frame:
// the image's top-left corner at (0, 0)). Then points seen by fewer than 2 images and images
// seeing fewer than kMinImageObservations points are dropped, repeatedly until neither happens
// (so a world may have fewer cameras and points than asked for); the rest keep their order.
//
// The camera (one for every image): fx = fy = focal, no skew, principal point at the image
// centre (width/2, height/2), radial distortion k1, k2: Cal3_S2 for the PINHOLE model (k1 = k2
// = 0), Cal3DS2 with p1 = p2 = 0 for OPENCV. Written as BAL, each image gets its own
// Cal3Bundler(focal, k1, k2) with pixels measured from the principal point: the same projection.
//
// Measurements: the true pixel plus N(0, sigma_pixel²) on each axis (noise_free: none).
// Observations are ordered image by image, points ascending within an image (so BAL and COLMAP
// files list them in the same order). Outliers: round(outliers · observations), picked at random,
// have their pixel replaced by one uniform in the image (a wrong match).
// Initial guess (the problem to solve): each pose T_wc·Exp(ξ), ξ = (σc·n, σr·n) with n ~ N(0, I₃)
// (init_sigma_camera, init_sigma_rotation), each point moved by init_sigma_point·n; the
// calibration is the true one.
// Stereo (params.stereo): each image is the left camera of a rectified pair whose right camera
// sits `baseline` metres along the image's +x (core/geometry/camera.h, Cal3_S2Stereo of the
// camera's pinhole part: rectified images have no distortion). Every observation that is not an
// outlier and whose point the right camera also sees inside its image gets (uL, uR, v): the true
// stereo projection plus N(0, sigma_pixel²) on each of the three.
//
// Complexity: O(cameras · points) projections (city: times the buildings, for occlusion).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/geometry/eigen_types.h"
#include "core/sfm/reconstruction.h"

namespace slamd::clients::sim {

enum class CameraWorldKind { kCity, kObject };
// COLMAP's model of the world's camera.
enum class CameraModel { kPinhole, kOpenCv };
// Which files WriteCameraWorld writes.
enum class CameraFormat { kBal, kColmap, kBoth };

// "camera-city", "camera-object" (and back; false for an unknown name).
const char* CameraWorldKindName(CameraWorldKind kind);
bool ParseCameraWorldKind(const std::string& name, CameraWorldKind* kind);

inline constexpr double kCityBlock = 40.0;     // m, from one street's centre line to the next
inline constexpr double kCityStreet = 12.0;    // m, between facades across a street
inline constexpr double kCityStep = 4.0;       // m along the street between images
inline constexpr double kCityMaxDepth = 80.0;  // m, farthest point a city camera sees
inline constexpr int kMinImageObservations = 8;

struct CameraSimParams {
  CameraWorldKind world = CameraWorldKind::kCity;
  std::uint64_t seed = 1;  // seeds std::mt19937_64
  int cameras = 0;         // images asked for, >= 2; 0 = the world's default (DefaultCameras)
  int points = 0;          // points placed, >= 1; 0 = the world's default (DefaultPoints)
  int width = 640;         // image size in pixels, [16, 100000]
  int height = 480;
  double focal = 500.0;  // pixels, > 0
  CameraModel model = CameraModel::kPinhole;
  double k1 = 0.0, k2 = 0.0;       // radial distortion (OPENCV only; 0 for PINHOLE)
  double sigma_pixel = 1.0;        // measurement noise per pixel axis, px (>= 0)
  double outliers = 0.0;           // fraction of observations replaced by wrong matches, [0, 1]
  bool noise_free = false;         // no pixel noise (outliers and the initial guess's noise stay)
  double init_sigma_camera = 0.1;  // initial guess: camera position noise per axis, m (>= 0)
  double init_sigma_rotation = 0.01;  // initial guess: camera rotation noise per axis, rad (>= 0)
  double init_sigma_point = 0.1;      // initial guess: point noise per axis, m (>= 0)
  bool stereo = false;                // also generate stereo measurements (file comment)
  double baseline = 0.5;              // stereo baseline, m (> 0)

  // Every range above; the message names the field ("CameraSimParams::focal = 0; violates > 0").
  core::Status Validate() const;
};

int DefaultCameras(CameraWorldKind kind);  // city 60, object 36
int DefaultPoints(CameraWorldKind kind);   // city 6000, object 1500

// A stereo measurement of one observation.
struct StereoObservation {
  int observation = 0;                        // index into the reconstructions' observations
  core::Vector3 uuv = core::Vector3::Zero();  // measured (uL, uR, v), pixels (COLMAP's frame)
};

struct CameraWorld {
  CameraSimParams params;  // as given, with cameras and points resolved to the counts asked for
  // The true cameras and points with the measured observations. One intrinsics (COLMAP camera
  // id 1, model PINHOLE or OPENCV, the image size), images named image_0001.png, ... with ids
  // from 1, points with ids from 1 and their colour.
  core::Reconstruction truth;
  // The same with the initial guess's poses and points (the problem a solver starts from).
  core::Reconstruction initial;
  std::vector<int> outliers;              // indices of the outlier observations, ascending
  std::vector<StereoObservation> stereo;  // params.stereo: in observation order
};

// Validates `params` and generates the world. kInvalidArgument for invalid params, or when no
// image keeps kMinImageObservations points (too few points for the world).
core::Result<CameraWorld> GenerateCameraWorld(const CameraSimParams& params);

// The reconstruction as BAL holds it: one Cal3Bundler(focal, k1, k2) per image, pixels relative
// to the principal point (the same reprojection errors).
core::Reconstruction AsBal(const core::Reconstruction& r);

// Writes the world into directory `dir` (which must exist) and appends the names written to
// `written`: problem.bal and groundtruth.bal (kBal, kBoth), colmap/ and groundtruth_colmap/
// (COLMAP text models; kColmap, kBoth), outliers.txt, and with params.stereo stereo.txt. The
// two text files' formats are in their '#' headers. (Implemented in sim_camera_world_io.cc.)
core::Status WriteCameraWorld(const CameraWorld& world, CameraFormat format, const std::string& dir,
                              std::vector<std::string>* written);

// stereo.txt read back: the baseline [m] and the measurements in observation order.
struct StereoFile {
  double baseline = 0.0;
  std::vector<StereoObservation> stereo;
};
// kNotFound when the file cannot be opened; kInvalidArgument naming the line that does not
// parse (the format is in the file's '#' header).
core::Result<StereoFile> ReadStereoFile(const std::string& path);

}  // namespace slamd::clients::sim
