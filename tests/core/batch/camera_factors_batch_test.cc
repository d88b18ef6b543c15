// Bundle adjustment through the batch solver with the camera factors (core/factors/
// projection_factor.h, stereo_projection_factor.h): a ring of cameras around a cloud of points,
// exact measurements and a perturbed start; priors on two poses fix the gauge and the scale.
#include <gtest/gtest.h>

#include <random>

#include "core/batch/batch_solver.h"
#include "core/factors/prior_factor.h"
#include "core/factors/projection_factor.h"
#include "core/factors/stereo_projection_factor.h"
#include "tests/testing/camera_examples.h"

namespace slamd::core {
namespace {

constexpr int kRingCameras = 8;
constexpr int kRingPoints = 20;

// A body on a circle of radius 6 m around the origin whose mounted camera looks at the origin.
Pose3 RingBody(int i, const Pose3& mount) {
  const double angle = 2.0 * kPi * i / kRingCameras;
  const Point3 eye(6.0 * std::cos(angle), 6.0 * std::sin(angle), 0.5 * (i % 3));
  return testing::LookAt(eye, Point3::Zero()) * mount.Inverse();
}

struct RingProblem {
  FactorGraph graph;
  Values truth;
  Values initial;
};

// Bodies x0..x7, points l0..l19 in a 2 m cube; every camera sees every point. `add` adds one
// observation factor of (body key, point key, body pose, point).
template <typename AddObservation>
RingProblem MakeRing(const Pose3& mount, unsigned seed, AddObservation add) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> cube(-1.0, 1.0), small(-1.0, 1.0);
  RingProblem p;
  for (int i = 0; i < kRingCameras; ++i) {
    const Pose3 body = RingBody(i, mount);
    EXPECT_TRUE(p.truth.Insert(MakeKey('x', i), body).ok());
    Vector6 xi;
    for (int k = 0; k < 6; ++k) xi[k] = (k < 3 ? 0.2 : 0.05) * small(rng);
    EXPECT_TRUE(p.initial.Insert(MakeKey('x', i), body.Retract(xi)).ok());
  }
  for (int j = 0; j < kRingPoints; ++j) {
    const Point3 point(cube(rng), cube(rng), cube(rng));
    EXPECT_TRUE(p.truth.Insert(MakeKey('l', j), point).ok());
    EXPECT_TRUE(p.initial
                    .Insert(MakeKey('l', j),
                            Point3(point + 0.2 * Point3(small(rng), small(rng), small(rng))))
                    .ok());
    for (int i = 0; i < kRingCameras; ++i) {
      add(MakeKey('x', i), MakeKey('l', j), p.truth.At<Pose3>(MakeKey('x', i)), point, &p.graph);
    }
  }
  // Two poses fixed: the gauge (6 dof) and the scale.
  for (int i : {0, 1}) {
    const Key key = MakeKey('x', i);
    p.graph.Add(std::make_shared<const PriorFactor<Pose3>>(key, p.truth.At<Pose3>(key),
                                                           *NoiseModel::Isotropic(6, 1e-3)));
  }
  return p;
}

void ExpectRecovered(const RingProblem& p) {
  const BatchResult result = Optimize(p.graph, p.initial);
  ASSERT_TRUE(result.status.ok()) << result.status.ToString();
  EXPECT_GT(result.summary.initial_chi2, 1e3) << "the start should be off";
  EXPECT_LT(result.summary.final_chi2, 1e-8) << result.summary.Brief();
  for (Key key : p.truth.keys()) {
    EXPECT_LT(LocalCoordinates(p.truth.Get(key), result.values.Get(key)).norm(), 1e-6)
        << KeyToString(key);
  }
}

template <typename Cal>
class CameraFactorsBatchTest : public ::testing::Test {};
using BatchCalibrations = ::testing::Types<Cal3_S2, Cal3DS2, Cal3Bundler>;
TYPED_TEST_SUITE(CameraFactorsBatchTest, BatchCalibrations);

TYPED_TEST(CameraFactorsBatchTest, MonocularRingRecoversTheTruth) {
  using Cal = TypeParam;
  std::mt19937 rng(3);
  const Cal K = testing::RandomCalibration<Cal>(rng);
  for (const Pose3& mount :
       {Pose3(), Pose3(Rot3::Exp(Vector3(0.1, -0.2, 0.05)), Point3(0.1, 0.0, 0.3))}) {
    const NoiseModel pixel = *NoiseModel::Isotropic(2, 1.0);
    ExpectRecovered(MakeRing(
        mount, 5, [&](Key x, Key l, const Pose3& body, const Point3& point, FactorGraph* graph) {
          const Vector2 uv = Project(body * mount, K, point).uv;
          graph->Add(std::make_shared<const ProjectionFactor<Cal>>(x, l, uv, K, pixel,
                                                                   RobustKernel(), mount));
        }));
  }
}

TEST(StereoFactorsBatchTest, StereoRingRecoversTheTruth) {
  std::mt19937 rng(7);
  const Cal3_S2Stereo K(testing::RandomCalibration<Cal3_S2>(rng), 0.3);
  const Pose3 mount(Rot3::Exp(Vector3(0.0, 0.1, 0.0)), Point3(-0.15, 0.0, 0.1));
  const NoiseModel pixel = *NoiseModel::Isotropic(3, 1.0);
  ExpectRecovered(MakeRing(
      mount, 9, [&](Key x, Key l, const Pose3& body, const Point3& point, FactorGraph* graph) {
        const Vector3 uuv = ProjectStereo(body * mount, K, point).uuv;
        graph->Add(std::make_shared<const StereoProjectionFactor>(x, l, uuv, K, pixel,
                                                                  RobustKernel(), mount));
      }));
}

}  // namespace
}  // namespace slamd::core
