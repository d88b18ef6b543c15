// Test helpers for reconstructions (core/sfm/reconstruction.h):
//  * BundlerReprojectionCost(r): ½ Σ |pixel - uv|² over r.observations with slamd's camera
//    convention, written out here rather than taken from core/geometry/camera.h, so that a
//    reader's conversion is checked against an independent formula: P_c = R_wcᵀ (X - t_wc),
//    p = P_c.xy / P_c.z, g = 1 + k1|p|² + k2|p|⁴, pixel = f·g·p (Cal3Bundler intrinsics only;
//    the pixels are relative to the principal point, so it does not enter).
//  * ExpectSameReconstruction(a, b, pose_tol, pixel_tol): everything equal, exactly except the
//    poses (max matrix entry difference <= pose_tol) and the pixels (<= pixel_tol).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <variant>

#include "core/sfm/reconstruction.h"

namespace slamd::testing {

inline double BundlerReprojectionCost(const core::Reconstruction& r) {
  double cost = 0.0;
  for (const core::SfmObservation& o : r.observations) {
    const core::SfmImage& image = r.images[o.image];
    const auto* K = std::get_if<core::Cal3Bundler>(&r.intrinsics[image.intrinsics].calibration);
    if (K == nullptr) {
      ADD_FAILURE() << "image " << o.image << " has no Cal3Bundler intrinsics";
      return NAN;
    }
    const Eigen::Matrix3d R_wc = image.pose.rotation().matrix();
    const Eigen::Vector3d P_c =
        R_wc.transpose() * (r.points[o.point].position - image.pose.translation());
    const Eigen::Vector2d p = P_c.head<2>() / P_c.z();
    const double r2 = p.squaredNorm();
    const double g = 1.0 + K->k1() * r2 + K->k2() * r2 * r2;
    cost += 0.5 * (K->f() * g * p - o.uv).squaredNorm();
  }
  return cost;
}

inline void ExpectSameReconstruction(const core::Reconstruction& a, const core::Reconstruction& b,
                                     double pose_tol, double pixel_tol) {
  ASSERT_EQ(a.intrinsics.size(), b.intrinsics.size());
  for (std::size_t k = 0; k < a.intrinsics.size(); ++k) {
    const core::SfmIntrinsics& x = a.intrinsics[k];
    const core::SfmIntrinsics& y = b.intrinsics[k];
    ASSERT_EQ(x.calibration.index(), y.calibration.index()) << "intrinsics " << k;
    std::visit(
        [&](const auto& cx) {
          using Cal = std::decay_t<decltype(cx)>;
          EXPECT_EQ(cx.vector(), std::get<Cal>(y.calibration).vector()) << "intrinsics " << k;
        },
        x.calibration);
    EXPECT_EQ(x.principal_point, y.principal_point) << "intrinsics " << k;
    EXPECT_EQ(x.model, y.model) << "intrinsics " << k;
    EXPECT_EQ(x.width, y.width) << "intrinsics " << k;
    EXPECT_EQ(x.height, y.height) << "intrinsics " << k;
    EXPECT_EQ(x.id, y.id) << "intrinsics " << k;
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (std::size_t i = 0; i < a.images.size(); ++i) {
    const core::SfmImage& x = a.images[i];
    const core::SfmImage& y = b.images[i];
    EXPECT_LE((x.pose.matrix() - y.pose.matrix()).cwiseAbs().maxCoeff(), pose_tol) << "image " << i;
    EXPECT_EQ(x.intrinsics, y.intrinsics) << "image " << i;
    EXPECT_EQ(x.name, y.name) << "image " << i;
    EXPECT_EQ(x.id, y.id) << "image " << i;
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t j = 0; j < a.points.size(); ++j) {
    const core::SfmPoint& x = a.points[j];
    const core::SfmPoint& y = b.points[j];
    EXPECT_EQ(x.position, y.position) << "point " << j;
    EXPECT_EQ(x.color, y.color) << "point " << j;
    EXPECT_EQ(x.error, y.error) << "point " << j;
    EXPECT_EQ(x.id, y.id) << "point " << j;
  }
  ASSERT_EQ(a.observations.size(), b.observations.size());
  for (std::size_t o = 0; o < a.observations.size(); ++o) {
    const core::SfmObservation& x = a.observations[o];
    const core::SfmObservation& y = b.observations[o];
    EXPECT_EQ(x.image, y.image) << "observation " << o;
    EXPECT_EQ(x.point, y.point) << "observation " << o;
    EXPECT_LE((x.uv - y.uv).cwiseAbs().maxCoeff(), pixel_tol) << "observation " << o;
  }
}

}  // namespace slamd::testing
