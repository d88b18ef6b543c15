#include "core/sfm/triangulation.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/camera.h"
#include "tests/testing/camera_examples.h"
#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::LookAt;
using testing::RandomCalibration;

// Views of one point: poses, calibrations and the pixels they see.
template <typename Cal>
struct Views {
  std::vector<Pose3> poses;
  std::vector<Cal> calibrations;
  std::vector<Vector2> pixels;

  Result<TriangulatedPoint> Triangulate(const TriangulationParams& params = {}) const {
    return core::Triangulate<Cal>(poses, calibrations, pixels, params);
  }
};

// n cameras 4-8 m from `point`, spread over a cone of ±40° around one direction, each looking
// near (not exactly at) the point, which they see with pixel noise of `sigma` px.
template <typename Cal>
Views<Cal> ViewsOf(const Point3& point, int n, double sigma, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), range(4.0, 8.0);
  std::normal_distribution<double> noise(0.0, sigma);
  Views<Cal> v;
  for (int i = 0; i < n; ++i) {
    const double azimuth = 0.7 * u(rng), elevation = 0.3 * u(rng);
    const Vector3 dir(std::cos(elevation) * std::cos(azimuth),
                      std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    const Point3 eye = point + range(rng) * dir;
    const Point3 aim = point + 0.5 * Vector3(u(rng), u(rng), u(rng));
    v.poses.push_back(LookAt(eye, aim));
    v.calibrations.push_back(RandomCalibration<Cal>(rng));
    v.pixels.push_back(Project(v.poses.back(), v.calibrations.back(), point).uv +
                       Vector2(noise(rng), noise(rng)));
  }
  return v;
}

// The stacked 2n x 3 Jacobian of the reprojection errors in the point, by central differences.
template <typename Cal>
Eigen::MatrixXd StackedJacobian(const Views<Cal>& v, const Point3& X) {
  return testing::NumericalJacobian(
      [&](const Eigen::VectorXd& x) {
        Eigen::VectorXd r(2 * v.poses.size());
        for (std::size_t i = 0; i < v.poses.size(); ++i) {
          r.segment<2>(2 * i) = Project(v.poses[i], v.calibrations[i], Point3(x)).uv - v.pixels[i];
        }
        return r;
      },
      X);
}

template <typename Cal>
class TriangulationTest : public ::testing::Test {};
using TriangulationCalibrations = ::testing::Types<Cal3_S2, Cal3DS2, Cal3Bundler>;
TYPED_TEST_SUITE(TriangulationTest, TriangulationCalibrations);

TYPED_TEST(TriangulationTest, NoiseFreeViewsGiveThePointExactly) {
  using Cal = TypeParam;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (int n : {2, 5}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Point3 point(u(rng), u(rng), u(rng));
      const Result<TriangulatedPoint> t = ViewsOf<Cal>(point, n, 0.0, rng).Triangulate();
      ASSERT_TRUE(t.ok()) << t.status().ToString();
      EXPECT_LT((t->position - point).norm(), 1e-9 * std::max(1.0, point.norm())) << n << " views";
      EXPECT_LT(t->rms_reprojection_px, 1e-8);
    }
  }
}

TYPED_TEST(TriangulationTest, NoisyViewsConvergeAndTheCovarianceIsTheInverseOfJtJ) {
  using Cal = TypeParam;
  std::mt19937 rng(5);
  const double sigma = 0.5;
  for (int trial = 0; trial < 10; ++trial) {
    const Point3 point(1.0, -2.0, 3.0);
    const Views<Cal> v = ViewsOf<Cal>(point, 5, sigma, rng);
    const Result<TriangulatedPoint> t = v.Triangulate();
    ASSERT_TRUE(t.ok()) << t.status().ToString();
    EXPECT_GE(t->iterations, 1);
    // Within 5 sigma of the truth, by the returned covariance scaled to the pixel noise.
    const Vector3 error = t->position - point;
    EXPECT_LT(error.dot((sigma * sigma * t->covariance).inverse() * error), 25.0 * 3.0);
    EXPECT_LT(t->rms_reprojection_px, 4.0 * sigma);
    // At the optimum of Σ|r|² the gradient Jᵀr vanishes, and the covariance is (JᵀJ)⁻¹.
    const Eigen::MatrixXd J = StackedJacobian(v, t->position);
    Eigen::VectorXd r(10);
    for (int i = 0; i < 5; ++i) {
      r.segment<2>(2 * i) = Project(v.poses[i], v.calibrations[i], t->position).uv - v.pixels[i];
    }
    EXPECT_LT((J.transpose() * r).norm(), 1e-6 * J.norm() * r.norm());
    EXPECT_NEAR(t->rms_reprojection_px, std::sqrt(r.squaredNorm() / 5.0), 1e-12);
    const Eigen::Matrix3d expected = (J.transpose() * J).inverse();
    EXPECT_LT(testing::MaxRelDiff(t->covariance / expected.norm(), expected / expected.norm()),
              1e-6)
        << "covariance:\n"
        << t->covariance << "\n(JᵀJ)⁻¹:\n"
        << expected;
  }
}

TEST(TriangulationDltTest, WithoutIterationsTheDltPointIsNoBetterThanGaussNewtons) {
  std::mt19937 rng(6);
  const Views<Cal3DS2> v = ViewsOf<Cal3DS2>(Point3(0.5, 0.5, 0.5), 4, 1.0, rng);
  const Result<TriangulatedPoint> dlt = v.Triangulate({.max_iterations = 0});
  const Result<TriangulatedPoint> refined = v.Triangulate();
  ASSERT_TRUE(dlt.ok() && refined.ok());
  EXPECT_EQ(dlt->iterations, 0);
  EXPECT_GE(refined->iterations, 1);
  EXPECT_LT(refined->rms_reprojection_px, dlt->rms_reprojection_px);
}

TEST(TriangulationFailureTest, FewerThanTwoViews) {
  std::mt19937 rng(7);
  Views<Cal3_S2> v = ViewsOf<Cal3_S2>(Point3(0, 0, 0), 1, 0.0, rng);
  const Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("1 view(s): triangulation needs at least 2"), std::string::npos)
      << s.message();
}

TEST(TriangulationFailureTest, SpansOfDifferentSizes) {
  std::mt19937 rng(9);
  Views<Cal3_S2> v = ViewsOf<Cal3_S2>(Point3(0, 0, 0), 3, 0.0, rng);
  v.pixels.pop_back();
  const Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("3 poses, 3 calibrations and 2 pixels"), std::string::npos)
      << s.message();
}

TEST(TriangulationFailureTest, NonFiniteInputNamesTheView) {
  std::mt19937 rng(11);
  const Views<Cal3DS2> good = ViewsOf<Cal3DS2>(Point3(0, 0, 0), 3, 0.0, rng);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Views<Cal3DS2> v = good;
  v.pixels[1].x() = nan;
  Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("view 1 (of 3): pixel is not finite"), std::string::npos)
      << s.message();
  v = good;
  v.calibrations[2] = Cal3DS2(Cal3_S2(nan, 500, 0, 320, 240), 0, 0, 0, 0);
  s = v.Triangulate().status();
  EXPECT_NE(s.message().find("view 2 (of 3): calibration is not finite"), std::string::npos)
      << s.message();
  v = good;
  v.poses[0] = Pose3(Rot3(), Point3(0, std::numeric_limits<double>::infinity(), 0));
  s = v.Triangulate().status();
  EXPECT_NE(s.message().find("view 0 (of 3): pose is not finite"), std::string::npos)
      << s.message();
}

TEST(TriangulationFailureTest, InvalidParamsNameTheField) {
  std::mt19937 rng(13);
  const Views<Cal3_S2> v = ViewsOf<Cal3_S2>(Point3(0, 0, 0), 2, 0.0, rng);
  Status s = v.Triangulate({.max_iterations = -1}).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("TriangulationParams::max_iterations = -1"), std::string::npos)
      << s.message();
  s = v.Triangulate({.max_reprojection_px = 0.0}).status();
  EXPECT_NE(s.message().find("max_reprojection_px"), std::string::npos) << s.message();
  s = v.Triangulate({.min_parallax_deg = 180.0}).status();
  EXPECT_NE(s.message().find("min_parallax_deg"), std::string::npos) << s.message();
}

TEST(TriangulationFailureTest, ParallaxBelowTheThreshold) {
  // Two cameras 2 cm apart, 10 m from the point: about 0.11 degrees between the rays.
  const Point3 point(0, 0, 10);
  const Cal3_S2 K(500, 500, 0, 320, 240);
  Views<Cal3_S2> v;
  for (double x : {-0.01, 0.01}) {
    v.poses.push_back(LookAt(Point3(x, -10, 10), point));
    v.calibrations.push_back(K);
    v.pixels.push_back(Project(v.poses.back(), K, point).uv);
  }
  const Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("parallax 0.11"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("min_parallax_deg = 1"), std::string::npos) << s.message();
  // A lower threshold accepts it: the data are exact.
  const Result<TriangulatedPoint> t = v.Triangulate({.min_parallax_deg = 0.05});
  ASSERT_TRUE(t.ok()) << t.status().ToString();
  EXPECT_LT((t->position - point).norm(), 1e-6);
}

TEST(TriangulationFailureTest, PointBehindACameraNamesTheView) {
  // Views 0 and 1 see the point; view 2 sits past it, looking away, and its pixel is the
  // formula's projection of the point behind it (on the same line).
  std::mt19937 rng(15);
  const Point3 point(1, 2, 3);
  Views<Cal3Bundler> v = ViewsOf<Cal3Bundler>(point, 2, 0.0, rng);
  const Point3 eye = point + Vector3(0.0, 3.0, 0.5);
  v.poses.push_back(LookAt(eye, eye + (eye - point)));
  v.calibrations.push_back(RandomCalibration<Cal3Bundler>(rng));
  const Projection behind = Project(v.poses.back(), v.calibrations.back(), point);
  ASSERT_FALSE(behind.in_front());
  v.pixels.push_back(behind.uv);
  const Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("behind view 2 (of 3) (depth -3.04"), std::string::npos)
      << s.message();
}

TEST(TriangulationFailureTest, ReprojectionErrorAboveTheThresholdGivesTheValue) {
  std::mt19937 rng(17);
  Views<Cal3_S2> v = ViewsOf<Cal3_S2>(Point3(0, 0, 0), 3, 0.0, rng);
  v.pixels[0] += Vector2(40.0, -30.0);  // an outlier
  const Status s = v.Triangulate().status();
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(s.message().find("RMS reprojection error "), std::string::npos) << s.message();
  EXPECT_NE(s.message().find(" px exceeds TriangulationParams::max_reprojection_px = 4"),
            std::string::npos)
      << s.message();
  // The same views pass with a looser threshold, reporting that error.
  const Result<TriangulatedPoint> t = v.Triangulate({.max_reprojection_px = 100.0});
  ASSERT_TRUE(t.ok()) << t.status().ToString();
  EXPECT_GT(t->rms_reprojection_px, 4.0);
}

TEST(TriangulationFailureTest, ParallelRaysPutThePointAtInfinity) {
  // Both cameras look down +z and see the principal point: parallel rays, zero parallax.
  const Cal3_S2 K(500, 500, 0, 320, 240);
  const Views<Cal3_S2> v{.poses = {Pose3(), Pose3(Rot3(), Point3(1, 0, 0))},
                         .calibrations = {K, K},
                         .pixels = {Vector2(320, 240), Vector2(320, 240)}};
  EXPECT_EQ(v.Triangulate().status().code(), StatusCode::kFailedPrecondition);
  const Status s = v.Triangulate({.min_parallax_deg = 0.0}).status();
  EXPECT_EQ(s.code(), StatusCode::kNumericalFailure);
  EXPECT_NE(s.message().find("infinity"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace slamd::core
