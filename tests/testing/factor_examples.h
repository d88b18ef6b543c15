// One example of every registered factor type (core/factors/factor_registry.cc) at random values,
// for the tests that run over all of them: Jacobians, record and snapshot round trips, export.
// Adding a factor type: add its example here (FactorExamplesTest checks that every registered
// type has one).
#pragma once

#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/factor_registry.h"
#include "core/factors/linear_container_factor.h"
#include "core/factors/position_prior_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/projection_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/factors/stereo_projection_factor.h"
#include "tests/testing/camera_examples.h"
#include "tests/testing/factor_testing.h"
#include "tests/testing/random_values.h"

namespace slamd::testing {

// A full-covariance noise model of dimension n.
inline core::NoiseModel RandomNoise(std::mt19937& rng, int n) {
  return core::NoiseModel::FromCovariance(0.01 * RandomSpd(rng, n)).value();
}

struct FactorExample {
  core::FactorPtr factor;
  core::Values values;  // every key of the factor
};

namespace internal {

template <typename T>
FactorExample PriorExample(std::mt19937& rng) {
  FactorExample e;
  const core::Key key = core::MakeKey('c', 0);
  e.factor = std::make_shared<const core::PriorFactor<T>>(
      key, RandomValue<T>(rng), RandomNoise(rng, core::VariableTraits<T>::kDim));
  EXPECT_TRUE(e.values.Insert(key, RandomValue<T>(rng)).ok());
  return e;
}

template <std::size_t... I>
std::vector<FactorExample> PriorsOfEveryKind(std::mt19937& rng, std::index_sequence<I...>) {
  return {PriorExample<std::variant_alternative_t<I, core::Variable>>(rng)...};
}

template <typename A, typename B>
core::Values TwoValues(std::mt19937& rng, core::Key ka, core::Key kb) {
  core::Values v;
  EXPECT_TRUE(v.Insert(ka, RandomValue<A>(rng)).ok());
  EXPECT_TRUE(v.Insert(kb, RandomValue<B>(rng)).ok());
  return v;
}

// The camera factors' values: a body pose x0 with a camera mounted at `mount`, and a landmark
// l0 ahead of that camera.
inline core::Values CameraValues(std::mt19937& rng, const core::Pose3& mount) {
  core::Values v;
  const core::Pose3 pose = RandomPose3(rng);
  EXPECT_TRUE(v.Insert(core::MakeKey('x', 0), pose).ok());
  EXPECT_TRUE(
      v.Insert(core::MakeKey('l', 0), (pose * mount).TransformFrom(RandomPointAhead(rng))).ok());
  return v;
}

// A pixel near the centre of a 640 x 480 image.
inline core::Vector2 RandomPixel(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  return core::Vector2(320.0 + u(rng), 240.0 + u(rng));
}

// ProjectionFactor<Cal> and SelfCalibratingProjectionFactor<Cal>, on a mounted camera.
template <typename Cal>
void AddProjectionExamples(std::mt19937& rng, std::vector<FactorExample>* out) {
  const core::Key x0 = core::MakeKey('x', 0), l0 = core::MakeKey('l', 0);
  const core::Key c0 = core::MakeKey('c', 0);
  const core::Pose3 mount = RandomPose3(rng);
  out->push_back({std::make_shared<const core::ProjectionFactor<Cal>>(
                      x0, l0, RandomPixel(rng), RandomCalibration<Cal>(rng), RandomNoise(rng, 2),
                      core::RobustKernel(), mount),
                  CameraValues(rng, mount)});
  FactorExample self{
      std::make_shared<const core::SelfCalibratingProjectionFactor<Cal>>(
          x0, l0, c0, RandomPixel(rng), RandomNoise(rng, 2), core::RobustKernel(), mount),
      CameraValues(rng, mount)};
  EXPECT_TRUE(self.values.Insert(c0, RandomCalibration<Cal>(rng)).ok());
  out->push_back(self);
}

}  // namespace internal

inline std::vector<FactorExample> EveryFactorTypeExample(unsigned seed) {
  using namespace core;  // NOLINT: the factor names read better unqualified here
  std::mt19937 rng(seed);
  std::vector<FactorExample> out =
      internal::PriorsOfEveryKind(rng, core::internal::VariableIndices{});
  const Key x0 = MakeKey('x', 0), x1 = MakeKey('x', 1), l0 = MakeKey('l', 0);
  out.push_back(
      {std::make_shared<const BetweenFactor<Pose2>>(x0, x1, RandomPose2(rng), RandomNoise(rng, 3)),
       internal::TwoValues<Pose2, Pose2>(rng, x0, x1)});
  out.push_back(
      {std::make_shared<const BetweenFactor<Pose3>>(x0, x1, RandomPose3(rng), RandomNoise(rng, 6)),
       internal::TwoValues<Pose3, Pose3>(rng, x0, x1)});
  {
    FactorExample e{std::make_shared<const PositionPriorFactor<Pose2>>(x0, RandomValue<Point2>(rng),
                                                                       RandomNoise(rng, 2)),
                    {}};
    EXPECT_TRUE(e.values.Insert(x0, RandomPose2(rng)).ok());
    out.push_back(e);
  }
  {
    FactorExample e{std::make_shared<const PositionPriorFactor<Pose3>>(x0, RandomValue<Point3>(rng),
                                                                       RandomNoise(rng, 3)),
                    {}};
    EXPECT_TRUE(e.values.Insert(x0, RandomPose3(rng)).ok());
    out.push_back(e);
  }
  {
    // A landmark 2-4 m away, so that the bearing is well defined.
    FactorExample e{
        std::make_shared<const BearingRangeFactor>(x0, l0, 0.3, 2.5, RandomNoise(rng, 2)), {}};
    const Pose2 pose = RandomPose2(rng);
    EXPECT_TRUE(e.values.Insert(x0, pose).ok());
    EXPECT_TRUE(e.values.Insert(l0, pose.TransformFrom(Point2(2.0, 1.5))).ok());
    out.push_back(e);
  }
  out.push_back({std::make_shared<const RelativePointFactor<Pose2, Point2>>(
                     x0, l0, RandomValue<Point2>(rng), RandomNoise(rng, 2)),
                 internal::TwoValues<Pose2, Point2>(rng, x0, l0)});
  out.push_back({std::make_shared<const RelativePointFactor<Pose3, Point3>>(
                     x0, l0, RandomValue<Point3>(rng), RandomNoise(rng, 3)),
                 internal::TwoValues<Pose3, Point3>(rng, x0, l0)});
  {
    // Over three variables of different kinds, at its linearisation point (where the first-order
    // rule's Jacobians A are the exact ones).
    const Key c0 = MakeKey('c', 0);
    FactorExample e;
    std::vector<Variable> x = {RandomPose3(rng), RandomValue<Point3>(rng),
                               RandomValue<Cal3DS2>(rng)};
    EXPECT_TRUE(e.values.Insert(x0, x[0]).ok());
    EXPECT_TRUE(e.values.Insert(l0, x[1]).ok());
    EXPECT_TRUE(e.values.Insert(c0, x[2]).ok());
    std::normal_distribution<double> n01(0.0, 1.0);
    Eigen::MatrixXd A(7, 6 + 3 + 9);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = n01(rng);
    Eigen::VectorXd b(7);
    for (int i = 0; i < b.size(); ++i) b[i] = n01(rng);
    e.factor = LinearContainerFactor::Create({x0, l0, c0}, x, A, b).value();
    out.push_back(e);
  }
  {
    // The root-relative form, a pose and a point in a root pose's frame, away from x₀.
    const Key x1 = MakeKey('x', 1);
    FactorExample e;
    const std::vector<Variable> x = {RandomValue<Pose2>(rng), RandomValue<Point2>(rng),
                                     RandomValue<Pose2>(rng)};
    EXPECT_TRUE(e.values.Insert(x0, RandomValue<Pose2>(rng)).ok());
    EXPECT_TRUE(e.values.Insert(l0, RandomValue<Point2>(rng)).ok());
    EXPECT_TRUE(e.values.Insert(x1, RandomValue<Pose2>(rng)).ok());
    std::normal_distribution<double> n01(0.0, 1.0);
    Eigen::MatrixXd A(4, 3 + 2);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = n01(rng);
    Eigen::VectorXd b(4);
    for (int i = 0; i < b.size(); ++i) b[i] = n01(rng);
    e.factor = LinearContainerFactor::CreateRootRelative({x0, l0, x1}, x, A, b).value();
    out.push_back(e);
  }
  internal::AddProjectionExamples<Cal3_S2>(rng, &out);
  internal::AddProjectionExamples<Cal3DS2>(rng, &out);
  internal::AddProjectionExamples<Cal3Bundler>(rng, &out);
  {
    const Pose3 mount = RandomPose3(rng);
    const Vector2 left = internal::RandomPixel(rng);
    out.push_back({std::make_shared<const StereoProjectionFactor>(
                       x0, l0, Vector3(left.x(), left.x() - 20.0, left.y()),
                       Cal3_S2Stereo(RandomCalibration<Cal3_S2>(rng), 0.12), RandomNoise(rng, 3),
                       RobustKernel(), mount),
                   internal::CameraValues(rng, mount)});
  }
  return out;
}

}  // namespace slamd::testing
