// Camera covariances (core/ba/camera_covariance.h) against the dense inverse of the full
// Gauss-Newton matrix JᵀJ, J by central differences over every camera and point unknown, with
// the same gauge unknowns removed.
#include "core/ba/camera_covariance.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>

#include "core/ba/bundle_adjuster.h"
#include "tests/testing/ba_worlds.h"

namespace slamd::core {
namespace {

// Full-system camera covariances of `r` (Cal3Bundler, calibrations refined when `refine`).
std::vector<Eigen::MatrixXd> DenseCameraCovariances(const Reconstruction& r, bool refine,
                                                    const CameraCovariances& gauge) {
  const int kD = refine ? 9 : 6;
  const int n = static_cast<int>(r.images.size()), p = static_cast<int>(r.points.size());
  const int dim = kD * n + 3 * p, m = 2 * static_cast<int>(r.observations.size());
  const Eigen::MatrixXd J = testing::BaNumericalJacobian(r, refine);
  std::vector<int> kept;
  for (int k = 0; k < dim; ++k) {
    if (k < 6 || k == kD * gauge.scale_image + gauge.scale_axis) continue;
    kept.push_back(k);
  }
  Eigen::MatrixXd Jk(m, kept.size());
  for (size_t a = 0; a < kept.size(); ++a) Jk.col(a) = J.col(kept[a]);
  const Eigen::MatrixXd inverse = (Jk.transpose() * Jk).inverse();
  Eigen::MatrixXd full = Eigen::MatrixXd::Zero(dim, dim);
  for (size_t a = 0; a < kept.size(); ++a) {
    for (size_t c = 0; c < kept.size(); ++c) full(kept[a], kept[c]) = inverse(a, c);
  }
  std::vector<Eigen::MatrixXd> out;
  for (int i = 0; i < n; ++i) out.push_back(full.block(kD * i, kD * i, kD, kD));
  return out;
}

TEST(CameraCovarianceTest, EqualsTheDenseInverseOfTheFullSystem) {
  for (bool refine : {false, true}) {
    Reconstruction r = testing::BaWorld(Cal3Bundler(500.0, -0.05, 0.01), 5, 25, 0.5, 21);
    testing::BaPerturb(&r, 0.01, 0.05, 22);
    BundleAdjusterParams params{.refine_intrinsics = refine, .max_iterations = 100};
    ASSERT_TRUE(BundleAdjust(params, &r).ok());
    const Result<CameraCovariances> cov = EstimateCameraCovariances(r, params, 0.5);
    ASSERT_TRUE(cov.ok()) << cov.status().ToString();
    // The sparse path (every size above the dense limit of 0): the same blocks.
    const Result<CameraCovariances> sparse = EstimateCameraCovariances(r, params, 0.5, 0);
    ASSERT_TRUE(sparse.ok()) << sparse.status().ToString();
    EXPECT_EQ(sparse->scale_image, cov->scale_image);
    EXPECT_EQ(sparse->scale_axis, cov->scale_axis);
    EXPECT_EQ(cov->block_dim, refine ? 9 : 6);
    EXPECT_EQ(cov->gauge_image, 0);
    EXPECT_NE(cov->scale_image, 0);
    const std::vector<Eigen::MatrixXd> dense = DenseCameraCovariances(r, refine, *cov);
    ASSERT_EQ(cov->per_image.size(), dense.size());
    for (size_t i = 0; i < dense.size(); ++i) {
      const Eigen::MatrixXd expected = 0.25 * dense[i];  // pixel sigma 0.5
      EXPECT_LT((cov->per_image[i] - expected).norm(), 1e-5 * expected.norm() + 1e-12)
          << "image " << i << (refine ? " (calibration refined)" : "") << "\n"
          << cov->per_image[i] << "\nexpected\n"
          << expected;
      EXPECT_LT((sparse->per_image[i] - expected).norm(), 1e-5 * expected.norm() + 1e-12)
          << "image " << i << " sparse" << (refine ? " (calibration refined)" : "");
    }
    EXPECT_TRUE((cov->per_image[0].topLeftCorner<6, 6>().isZero()));  // the gauge
  }
}

TEST(CameraCovarianceTest, RefusesWhatHasNoGaugeOrIsUnconstrained) {
  Reconstruction one = testing::BaWorld(Cal3Bundler(500.0, 0.0, 0.0), 1, 5, 0.0, 23);
  EXPECT_EQ(EstimateCameraCovariances(one, {}).status().code(), StatusCode::kFailedPrecondition);
  Reconstruction r = testing::BaWorld(Cal3Bundler(500.0, 0.0, 0.0), 4, 10, 0.0, 24);
  EXPECT_EQ(EstimateCameraCovariances(r, {}, -1.0).status().code(), StatusCode::kInvalidArgument);
  // A camera that sees nothing: singular beyond the gauge, in both paths.
  r.observations.erase(std::remove_if(r.observations.begin(), r.observations.end(),
                                      [](const SfmObservation& o) { return o.image == 2; }),
                       r.observations.end());
  for (int dense_limit : {6000, 0}) {
    const Status singular = EstimateCameraCovariances(r, {}, 1.0, dense_limit).status();
    EXPECT_EQ(singular.code(), StatusCode::kFailedPrecondition) << singular.ToString();
    EXPECT_NE(singular.message().find("singular beyond the gauge"), std::string::npos)
        << singular.ToString();
  }
}

}  // namespace
}  // namespace slamd::core
