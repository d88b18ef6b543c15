// The camera factors: ProjectionFactor<Cal>, SelfCalibratingProjectionFactor<Cal> (this file's
// header) and StereoProjectionFactor (stereo_projection_factor.h), which share camera_mount.h.
#include "core/factors/projection_factor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/factors/factor_registry.h"
#include "core/factors/stereo_projection_factor.h"
#include "tests/testing/camera_examples.h"
#include "tests/testing/factor_testing.h"

namespace slamd::core {
namespace {

using testing::kL;
using testing::kX;
using testing::RandomCalibration;
using testing::RandomPointAhead;
const Key kCal = MakeKey('c', 0);

// A camera mounted ~20 cm off the body and turned by up to ~30°.
Pose3 ProjectionTestMount(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Pose3(Rot3::Exp(0.3 * Vector3(u(rng), u(rng), u(rng))),
               Point3(0.1 * u(rng), 0.1 * u(rng), 0.2));
}

// Pose x0 and landmark l0, the landmark at camera-frame point p_c of the camera on the body.
Values ProjectionTestValues(const Pose3& body, const Pose3& mount, const Point3& p_c) {
  Values v;
  EXPECT_TRUE(v.Insert(kX, body).ok());
  EXPECT_TRUE(v.Insert(kL, (body * mount).TransformFrom(p_c)).ok());
  return v;
}

NoiseModel PixelNoise(int dim, double sigma) { return *NoiseModel::Isotropic(dim, sigma); }

// The robust factor's linearisation is the plain one scaled by √ρ'(|R·e|²) (factor.h).
void ExpectScaledByRobustWeight(const Factor& plain, const Factor& robust, const Values& v) {
  LinearizedFactor a, b;
  plain.Linearize(v, &a);
  robust.Linearize(v, &b);
  const double sqrt_w = std::sqrt(robust.robust_kernel().Weight(plain.Chi2(v)));
  EXPECT_LT(sqrt_w, 0.99) << "the test wants a residual beyond the kernel's threshold";
  EXPECT_LT((Eigen::MatrixXd(b.Ab()) - sqrt_w * Eigen::MatrixXd(a.Ab())).cwiseAbs().maxCoeff(),
            1e-9 * Eigen::MatrixXd(a.Ab()).cwiseAbs().maxCoeff());
}

// The record round trip through the registry rebuilds a factor with the same error.
void ExpectRoundTrip(const Factor& f, const Values& v) {
  const FactorRecord record = EncodeFactor(f);
  Result<FactorPtr> back = DecodeFactor(record);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_STREQ((*back)->Name(), f.Name());
  EXPECT_EQ(ToKeyVector((*back)->keys()), ToKeyVector(f.keys()));
  EXPECT_EQ((*back)->robust_kernel().kind(), f.robust_kernel().kind());
  EXPECT_EQ(Eigen::VectorXd((*back)->Error(v)), Eigen::VectorXd(f.Error(v)));
  EXPECT_EQ(EncodeFactor(**back).measured, record.measured);
}

template <typename Cal>
class ProjectionFactorTest : public ::testing::Test {};
using ProjectionCalibrations = ::testing::Types<Cal3_S2, Cal3DS2, Cal3Bundler>;
TYPED_TEST_SUITE(ProjectionFactorTest, ProjectionCalibrations);

TYPED_TEST(ProjectionFactorTest, ErrorIsThePixelOfTheMountedCameraMinusTheMeasurement) {
  using Cal = TypeParam;
  std::mt19937 rng(3);
  const Cal K = RandomCalibration<Cal>(rng);
  const Pose3 body = testing::RandomPose3(rng), mount = ProjectionTestMount(rng);
  const Values v = ProjectionTestValues(body, mount, Point3(0.3, -0.2, 4.0));
  const Vector2 pixel = Project(body * mount, K, v.At<Point3>(kL)).uv;
  const Vector2 offset(1.5, -2.0);
  ProjectionFactor<Cal> f(kX, kL, pixel - offset, K, PixelNoise(2, 1.0), {}, mount);
  EXPECT_LT((Eigen::VectorXd(f.Error(v)) - offset).norm(), 1e-9);
  // Without the mount the body itself is the camera: another pixel.
  ProjectionFactor<Cal> unmounted(kX, kL, pixel, K, PixelNoise(2, 1.0));
  EXPECT_GT(Eigen::VectorXd(unmounted.Error(v)).norm(), 1.0);
  EXPECT_TRUE(unmounted.body_P_camera().Equals(Pose3(), 0.0));

  SelfCalibratingProjectionFactor<Cal> self(kX, kL, kCal, pixel - offset, PixelNoise(2, 1.0), {},
                                            mount);
  Values with_cal = v;
  ASSERT_TRUE(with_cal.Insert(kCal, K).ok());
  EXPECT_LT((Eigen::VectorXd(self.Error(with_cal)) - offset).norm(), 1e-9);
}

TYPED_TEST(ProjectionFactorTest, JacobiansMatchNumerical) {
  using Cal = TypeParam;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> noise(-3.0, 3.0);
  for (int trial = 0; trial < 10; ++trial) {
    const Cal K = RandomCalibration<Cal>(rng);
    const Pose3 body = testing::RandomPose3(rng);
    const Pose3 mount = trial % 2 == 0 ? Pose3() : ProjectionTestMount(rng);
    Values v = ProjectionTestValues(body, mount, RandomPointAhead(rng));
    const Vector2 measured =
        Project(body * mount, K, v.At<Point3>(kL)).uv + Vector2(noise(rng), noise(rng));
    const NoiseModel model = *NoiseModel::FromCovariance(testing::RandomSpd(rng, 2));
    ProjectionFactor<Cal> f(kX, kL, measured, K, model, {}, mount);
    testing::ExpectJacobiansMatchNumerical(f, v, 1e-6);
    SelfCalibratingProjectionFactor<Cal> self(kX, kL, kCal, measured, model, {}, mount);
    ASSERT_TRUE(v.Insert(kCal, RandomCalibration<Cal>(rng)).ok());
    testing::ExpectJacobiansMatchNumerical(self, v, 1e-6);
  }
}

TYPED_TEST(ProjectionFactorTest, RobustKernelScalesTheWhitenedRows) {
  using Cal = TypeParam;
  std::mt19937 rng(7);
  const Cal K = RandomCalibration<Cal>(rng);
  const Pose3 body = testing::RandomPose3(rng), mount = ProjectionTestMount(rng);
  Values v = ProjectionTestValues(body, mount, Point3(-0.5, 0.4, 3.0));
  ASSERT_TRUE(v.Insert(kCal, K).ok());
  const Vector2 measured = Project(body * mount, K, v.At<Point3>(kL)).uv + Vector2(6.0, -4.0);
  const RobustKernel huber = *RobustKernel::Create(RobustKernel::Kind::kHuber, 1.345);
  const NoiseModel model = PixelNoise(2, 1.5);
  ExpectScaledByRobustWeight(ProjectionFactor<Cal>(kX, kL, measured, K, model, {}, mount),
                             ProjectionFactor<Cal>(kX, kL, measured, K, model, huber, mount), v);
  ExpectScaledByRobustWeight(
      SelfCalibratingProjectionFactor<Cal>(kX, kL, kCal, measured, model, {}, mount),
      SelfCalibratingProjectionFactor<Cal>(kX, kL, kCal, measured, model, huber, mount), v);
}

TYPED_TEST(ProjectionFactorTest, RecordRoundTripKeepsCalibrationMountAndKernel) {
  using Cal = TypeParam;
  std::mt19937 rng(9);
  const Cal K = RandomCalibration<Cal>(rng);
  const Pose3 body = testing::RandomPose3(rng), mount = ProjectionTestMount(rng);
  Values v = ProjectionTestValues(body, mount, Point3(0.2, 0.1, 5.0));
  ASSERT_TRUE(v.Insert(kCal, RandomCalibration<Cal>(rng)).ok());
  const RobustKernel cauchy = *RobustKernel::Create(RobustKernel::Kind::kCauchy, 2.0);
  const ProjectionFactor<Cal> f(kX, kL, Vector2(300.5, 250.25), K, PixelNoise(2, 0.7), cauchy,
                                mount);
  ExpectRoundTrip(f, v);
  // (u, v), then the calibration, then the mount.
  const FactorRecord r = EncodeFactor(f);
  ASSERT_EQ(static_cast<int>(r.measured.size()), 2 + Cal::kDim + 12);
  EXPECT_EQ(r.measured[0], 300.5);
  EXPECT_EQ(r.measured[2], K.vector()[0]);
  EXPECT_EQ(r.measured[2 + Cal::kDim], mount.translation().x());
  ExpectRoundTrip(SelfCalibratingProjectionFactor<Cal>(kX, kL, kCal, Vector2(1, 2),
                                                       PixelNoise(2, 1.0), {}, mount),
                  v);
}

TYPED_TEST(ProjectionFactorTest, InFrontFollowsTheMountedCamera) {
  using Cal = TypeParam;
  std::mt19937 rng(11);
  const Cal K = RandomCalibration<Cal>(rng);
  const Pose3 body = testing::RandomPose3(rng), mount = ProjectionTestMount(rng);
  const ProjectionFactor<Cal> f(kX, kL, Vector2(320, 240), K, PixelNoise(2, 1.0), {}, mount);
  const SelfCalibratingProjectionFactor<Cal> self(kX, kL, kCal, Vector2(320, 240),
                                                  PixelNoise(2, 1.0), {}, mount);
  for (const double z : {3.0, -3.0}) {
    Values v = ProjectionTestValues(body, mount, Point3(0.1, 0.2, z));
    ASSERT_TRUE(v.Insert(kCal, K).ok());
    EXPECT_EQ(f.InFront(v), z > 0.0);
    EXPECT_EQ(self.InFront(v), z > 0.0);
    // Behind, the error is the formula's: finite, and its Jacobians do not vanish.
    LinearizedFactor lf;
    f.Linearize(v, &lf);
    EXPECT_TRUE(Eigen::MatrixXd(lf.Ab()).allFinite());
    EXPECT_GT(Eigen::MatrixXd(lf.Block(0)).norm(), 1.0);
  }
}

TYPED_TEST(ProjectionFactorTest, APixelPlacesNeitherThePoseNorTheLandmark) {
  using Cal = TypeParam;
  std::mt19937 rng(13);
  const ProjectionFactor<Cal> f(kX, kL, Vector2(320, 240), RandomCalibration<Cal>(rng),
                                PixelNoise(2, 1.0));
  EXPECT_FALSE(f.Predict(0, Pose3()).has_value());
  EXPECT_FALSE(f.Predict(1, Point3(1, 2, 3)).has_value());
}

TEST(ProjectionFactorRecordTest, BadRecordsAreRefusedWithTheLayout) {
  const ProjectionFactor<Cal3DS2> f(kX, kL, Vector2(320, 240),
                                    Cal3DS2(Cal3_S2(500, 500, 0, 320, 240), -0.2, 0.05, 0, 0),
                                    PixelNoise(2, 1.0));
  FactorRecord short_record = EncodeFactor(f);
  short_record.measured.pop_back();
  Status s = DecodeFactor(short_record).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("(u, v), Cal3DS2 (9) and body_P_camera (12) are 23 numbers, not 22"),
            std::string::npos)
      << s.message();
  FactorRecord nan_pixel = EncodeFactor(f);
  nan_pixel.measured[1] = std::numeric_limits<double>::quiet_NaN();
  s = DecodeFactor(nan_pixel).status();
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("not finite"), std::string::npos) << s.message();
  FactorRecord bad_mount = EncodeFactor(f);
  bad_mount.measured.back() = std::numeric_limits<double>::infinity();
  s = DecodeFactor(bad_mount).status();
  EXPECT_NE(s.message().find("body_P_camera"), std::string::npos) << s.message();
}

TEST(StereoProjectionFactorTest, ErrorJacobiansAndRoundTrip) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> noise(-2.0, 2.0);
  for (int trial = 0; trial < 10; ++trial) {
    const Cal3_S2Stereo K(RandomCalibration<Cal3_S2>(rng), 0.12);
    const Pose3 body = testing::RandomPose3(rng);
    const Pose3 mount = trial % 2 == 0 ? Pose3() : ProjectionTestMount(rng);
    const Values v = ProjectionTestValues(body, mount, RandomPointAhead(rng));
    const Vector3 offset(noise(rng), noise(rng), noise(rng));
    const Vector3 measured = ProjectStereo(body * mount, K, v.At<Point3>(kL)).uuv - offset;
    StereoProjectionFactor f(kX, kL, measured, K,
                             *NoiseModel::FromCovariance(testing::RandomSpd(rng, 3)), {}, mount);
    EXPECT_LT((Eigen::VectorXd(f.Error(v)) - offset).norm(), 1e-9);
    testing::ExpectJacobiansMatchNumerical(f, v, 1e-6);
    ExpectRoundTrip(f, v);
    const RobustKernel huber = *RobustKernel::Create(RobustKernel::Kind::kHuber, 0.1);
    ExpectScaledByRobustWeight(
        f, StereoProjectionFactor(kX, kL, measured, K, f.noise_model(), huber, mount), v);
  }
}

TEST(StereoProjectionFactorTest, PredictPlacesTheLandmarkWhereItWas) {
  std::mt19937 rng(19);
  const Cal3_S2Stereo K(RandomCalibration<Cal3_S2>(rng), 0.12);
  const Pose3 body = testing::RandomPose3(rng), mount = ProjectionTestMount(rng);
  const Values v = ProjectionTestValues(body, mount, Point3(0.4, -0.3, 6.0));
  const Point3 landmark = v.At<Point3>(kL);
  const StereoProjectionFactor f(kX, kL, ProjectStereo(body * mount, K, landmark).uuv, K,
                                 PixelNoise(3, 1.0), {}, mount);
  const std::optional<Variable> predicted = f.Predict(0, body);
  ASSERT_TRUE(predicted.has_value());
  EXPECT_LT((std::get<Point3>(*predicted) - landmark).norm(), 1e-9);
  EXPECT_FALSE(f.Predict(1, landmark).has_value());
}

TEST(StereoProjectionFactorTest, InFrontOfTheLeftCamera) {
  const Cal3_S2Stereo K(Cal3_S2(500, 500, 0, 320, 240), 0.12);
  const Pose3 mount(Rot3(), Point3(0.0, 0.0, 0.5));
  const StereoProjectionFactor f(kX, kL, Vector3(330, 320, 240), K, PixelNoise(3, 1.0), {}, mount);
  EXPECT_TRUE(f.InFront(ProjectionTestValues(Pose3(), mount, Point3(0, 0, 2))));
  EXPECT_FALSE(f.InFront(ProjectionTestValues(Pose3(), mount, Point3(0, 0, -0.1))));
}

}  // namespace
}  // namespace slamd::core
