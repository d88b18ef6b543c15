// The picture of a structure-from-motion reconstruction (core/sfm/reconstruction.h) for
// `slamctl plot`: which files hold one, which plane to look at it in, and the PlotReconstruction
// (plot_scene.h) of cameras and points in that plane.
//
// The plane is one of the world's coordinate planes, the lower axis of the two across the page
// and the other up it, so the axis left out points out of the page (x-y seen from +z, x-z from
// -y, y-z from +x: never mirrored). ChooseViewPlane leaves out the axis along which the camera
// centres spread least (their standard deviation), z when tied, then y: a top view for cameras
// that move over the ground (z up), and the plane of the ring for cameras around an object.
//
// A camera is drawn as a wedge from its centre along the two edges of a fixed view on the
// image's horizontal midline: the camera-frame directions (∓kWedgeHalfWidth, 0, 1), normalised,
// rotated into the world and projected into the plane. The wedge shows which way the camera
// looks (its opening is not the calibration's field of view); it shrinks to a line as the camera
// looks across the plane.
#pragma once

#include <string>
#include <vector>

#include "clients/slamctl/plot_scene.h"
#include "core/ba/camera_covariance.h"
#include "core/sfm/reconstruction.h"

namespace slamd::clients::plot {

enum class ViewPlane { kXY, kXZ, kYZ };

// "xy", "xz", "yz" (and back); kInvalidArgument for another name.
const char* ViewPlaneName(ViewPlane plane);
core::Result<ViewPlane> ParseViewPlane(const std::string& name);

inline constexpr double kWedgeHalfWidth = 0.5;  // tan of the wedge's half-opening (~27°)

// True when `path` is a reconstruction rather than a pose-graph dataset: a directory (a COLMAP
// text model) or a file whose first word (after blank lines and '#' comment lines) is an
// unsigned integer (a BAL file's camera count; the pose-graph formats start every record with
// a tag such as VERTEX_SE2, EDGE2 or ODOMETRY). False when the file cannot be read: the
// dataset reader then says why.
bool IsReconstructionPath(const std::string& path);

// See the file comment. An empty reconstruction gives kXY.
ViewPlane ChooseViewPlane(const core::Reconstruction& r);

// The cameras (in image order) and points (in point order, with their colours) of `r` in `plane`,
// no camera ellipses. extent: every camera centre, and the points' 1st to 99th percentile on
// each axis of the plane. `r` must be valid (Reconstruction::Validate).
PlotReconstruction BuildReconstruction(const core::Reconstruction& r, ViewPlane plane);

// The `sigma`-sigma ellipses of the camera centres in `plane` from their marginal covariances
// (core/ba/camera_covariance.h): a centre moves by R_wc·v for a pose step (v, ω), so its
// covariance is R_wc·Σ_vv·R_wcᵀ. The gauge camera's is empty and left out.
std::vector<Ellipse> CameraEllipses(const core::Reconstruction& r,
                                    const core::CameraCovariances& covariances, ViewPlane plane,
                                    double sigma);

// The titles of the plane's axes, e.g. "x [m]" and "z [m]" for kXZ.
std::string HorizontalLabel(ViewPlane plane);
std::string VerticalLabel(ViewPlane plane);

}  // namespace slamd::clients::plot
