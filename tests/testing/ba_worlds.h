// Test helpers for bundle adjustment: small synthetic reconstructions.
//  * BaWorld(cal, cameras, points, pixel_sigma, seed): cameras on a circle of radius 6 around a
//    cloud of points near the origin, looking at it; every camera sees a point except where
//    (camera + point) % 3 == 0 (with more than 3 cameras); pixels from the true values plus
//    Gaussian noise. One intrinsics per image.
//  * BaPerturb(r, pose_sigma, point_sigma, seed): every pose and point moved at random.
//  * BaNumericalJacobian(r, refine, &residuals): the Jacobian of every observation's pixel error
//    (Cal3Bundler intrinsics) by central differences over the stacked unknowns: each image's
//    pose (right perturbation) and, when `refine`, calibration, then every point — the
//    independent reference for the adjuster's Schur step and covariances.
//  * CentralDifferences(residuals, dim): the Jacobian of any residual function of a dim-vector.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <random>
#include <variant>

#include "core/geometry/camera.h"
#include "core/sfm/reconstruction.h"

namespace slamd::testing {

template <typename Cal>
inline core::Reconstruction BaWorld(const Cal& cal, int num_cameras, int num_points,
                                    double pixel_sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> cube(-1.5, 1.5);
  core::Reconstruction r;
  for (int i = 0; i < num_cameras; ++i) {
    const double a = 2.0 * core::kPi * i / num_cameras;
    const core::Point3 centre(6.0 * std::cos(a), 6.0 * std::sin(a), 0.5 * std::sin(3.0 * a));
    // z towards the origin, x tangent, y completing a right-handed frame (pointing down).
    const core::Vector3 z = -centre.normalized();
    const core::Vector3 x = core::Vector3(-std::sin(a), std::cos(a), 0.0).normalized();
    core::Matrix3 R;
    R.col(0) = x;
    R.col(1) = z.cross(x);
    R.col(2) = z;
    r.images.push_back({.pose = core::Pose3(core::Rot3(R), centre), .intrinsics = i});
    r.intrinsics.push_back({.calibration = cal});
  }
  for (int j = 0; j < num_points; ++j) {
    r.points.push_back({.position = core::Point3(cube(rng), cube(rng), cube(rng))});
  }
  for (int j = 0; j < num_points; ++j) {
    for (int i = 0; i < num_cameras; ++i) {
      if ((i + j) % 3 == 0 && num_cameras > 3) continue;  // not every camera sees every point
      const core::Projection p = core::Project(r.images[i].pose, cal, r.points[j].position);
      r.observations.push_back({.image = i,
                                .point = j,
                                .uv = p.uv + pixel_sigma * core::Vector2(noise(rng), noise(rng))});
    }
  }
  return r;
}

inline void BaPerturb(core::Reconstruction* r, double pose_sigma, double point_sigma,
                      unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (core::SfmImage& image : r->images) {
    core::Vector6 d;
    for (int k = 0; k < 6; ++k) d[k] = pose_sigma * noise(rng);
    image.pose = image.pose.Retract(d);
  }
  for (core::SfmPoint& p : r->points) {
    p.position += point_sigma * core::Vector3(noise(rng), noise(rng), noise(rng));
  }
}

// The Jacobian at δ = 0 of residuals(δ) (a function of a `dim`-vector) by central differences.
template <typename Residuals>
Eigen::MatrixXd CentralDifferences(const Residuals& residuals, int dim) {
  Eigen::MatrixXd J;
  for (int k = 0; k < dim; ++k) {
    Eigen::VectorXd h = Eigen::VectorXd::Zero(dim);
    h[k] = 1e-6;
    const Eigen::VectorXd column = (residuals(h) - residuals(-h)) / 2e-6;
    if (k == 0) J.resize(column.size(), dim);
    J.col(k) = column;
  }
  return J;
}

inline Eigen::MatrixXd BaNumericalJacobian(const core::Reconstruction& r, bool refine,
                                           Eigen::VectorXd* residuals_at_r = nullptr) {
  const int kD = refine ? 9 : 6;
  const int n = static_cast<int>(r.images.size());
  const int dim = kD * n + 3 * static_cast<int>(r.points.size());
  const int m = 2 * static_cast<int>(r.observations.size());
  auto residuals = [&](const Eigen::VectorXd& d) {
    Eigen::VectorXd out(m);
    for (size_t o = 0; o < r.observations.size(); ++o) {
      const core::SfmObservation& obs = r.observations[o];
      const core::SfmImage& image = r.images[obs.image];
      const core::Pose3 pose = image.pose.Retract(d.segment<6>(kD * obs.image));
      core::Cal3Bundler cal =
          std::get<core::Cal3Bundler>(r.intrinsics[image.intrinsics].calibration);
      if (refine) cal = cal.Retract(d.segment<3>(kD * obs.image + 6));
      const core::Point3 x = r.points[obs.point].position + d.segment<3>(kD * n + 3 * obs.point);
      out.segment<2>(2 * o) = core::Project(pose, cal, x).uv - obs.uv;
    }
    return out;
  };
  if (residuals_at_r) *residuals_at_r = residuals(Eigen::VectorXd::Zero(dim));
  return CentralDifferences(residuals, dim);
}

}  // namespace slamd::testing
