// Small example graphs with known structure, for solver tests (GTSAM smallExample.h in spirit).
#pragma once

#include <map>
#include <random>
#include <set>
#include <vector>

#include "core/factors/between_factor.h"
#include "core/factors/factor_graph.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"

namespace slamd::testing {

struct ExampleProblem {
  core::FactorGraph graph;
  core::Values initial;
  core::Values truth;
};

// A planar trajectory of `num_poses` poses on a loop, with odometry, a few loop closures, and
// `num_landmarks` landmarks each seen from several poses; noisy measurements and a perturbed
// initial guess. A prior anchors x0.
inline ExampleProblem MakePlanarProblem(int num_poses, int num_landmarks, unsigned seed) {
  using namespace core;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  ExampleProblem p;
  const NoiseModel odo = *NoiseModel::Diagonal(Vector3(0.05, 0.05, 0.02));
  const NoiseModel obs = *NoiseModel::Isotropic(2, 0.1);
  for (int i = 0; i < num_poses; ++i) {
    const double a = 2.0 * M_PI * i / num_poses;
    const Pose2 x(5.0 * std::cos(a), 5.0 * std::sin(a), a + M_PI / 2);
    (void)p.truth.Insert(MakeKey('x', i), x);
    (void)p.initial.Insert(MakeKey('x', i), x.Compose(Pose2(0.3 * n01(rng), 0.3 * n01(rng), 0.1 * n01(rng))));
  }
  auto noisy = [&](const Pose2& z) {
    return z.Compose(Pose2(0.05 * n01(rng), 0.05 * n01(rng), 0.02 * n01(rng)));
  };
  p.graph.Emplace<PriorFactor<Pose2>>(MakeKey('x', 0), p.truth.At<Pose2>(MakeKey('x', 0)),
                                      *NoiseModel::Isotropic(3, 0.01));
  for (int i = 0; i + 1 < num_poses; ++i) {
    const Key a = MakeKey('x', i), b = MakeKey('x', i + 1);
    p.graph.Emplace<BetweenFactor<Pose2>>(a, b, noisy(p.truth.At<Pose2>(a).Between(p.truth.At<Pose2>(b))), odo);
  }
  for (int i = 0; i + num_poses / 2 < num_poses; i += 3) {
    const Key a = MakeKey('x', i), b = MakeKey('x', i + num_poses / 2);
    p.graph.Emplace<BetweenFactor<Pose2>>(a, b, noisy(p.truth.At<Pose2>(a).Between(p.truth.At<Pose2>(b))), odo);
  }
  for (int j = 0; j < num_landmarks; ++j) {
    const Point2 l(8.0 * n01(rng) * 0.5, 8.0 * n01(rng) * 0.5);
    const Key lk = MakeKey('l', j);
    (void)p.truth.Insert(lk, l);
    (void)p.initial.Insert(lk, Point2(l + Point2(0.3 * n01(rng), 0.3 * n01(rng))));
    for (int k = 0; k < 4; ++k) {
      const Key x = MakeKey('x', (j * 7 + k * 5) % num_poses);
      const Point2 z = p.truth.At<Pose2>(x).TransformTo(l) + Point2(0.1 * n01(rng), 0.1 * n01(rng));
      p.graph.Emplace<RelativePointFactor<Pose2, Point2>>(x, lk, z, obs);
    }
  }
  return p;
}

// A 3D chain of poses with loop closures, anchored at x0.
inline ExampleProblem MakeSpatialProblem(int num_poses, unsigned seed) {
  using namespace core;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  ExampleProblem p;
  Eigen::Matrix<double, 6, 1> sigmas;
  sigmas << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  const NoiseModel noise = *NoiseModel::Diagonal(sigmas);
  auto perturb = [&](const Pose3& x, double s) {
    Vector6 d;
    for (int k = 0; k < 6; ++k) d[k] = s * n01(rng);
    return x.Compose(Pose3::Exp(d));
  };
  for (int i = 0; i < num_poses; ++i) {
    const double a = 2.0 * M_PI * i / num_poses;
    const Pose3 x(Rot3::FromRollPitchYaw(0.1 * std::sin(a), 0.05, a),
                  Point3(4.0 * std::cos(a), 4.0 * std::sin(a), 0.3 * i / num_poses));
    (void)p.truth.Insert(MakeKey('x', i), x);
    (void)p.initial.Insert(MakeKey('x', i), perturb(x, 0.05));
  }
  p.graph.Emplace<PriorFactor<Pose3>>(MakeKey('x', 0), p.truth.At<Pose3>(MakeKey('x', 0)),
                                      *NoiseModel::Isotropic(6, 0.01));
  auto link = [&](int i, int j) {
    const Key a = MakeKey('x', i), b = MakeKey('x', j);
    p.graph.Emplace<BetweenFactor<Pose3>>(a, b, perturb(p.truth.At<Pose3>(a).Between(p.truth.At<Pose3>(b)), 0.01), noise);
  };
  for (int i = 0; i + 1 < num_poses; ++i) link(i, i + 1);
  for (int i = 0; i + 4 < num_poses; i += 4) link(i, i + 4);
  link(0, num_poses - 1);
  return p;
}

// One incremental step of an example problem: new factors and the initial values they introduce.
struct ExampleStep {
  core::FactorGraph factors;
  core::Values values;
};

// The problem as one update per pose: pose i with every factor whose newest pose is i, and each
// variable's initial value at its first appearance (the protocol of the solver tests).
inline std::vector<ExampleStep> StreamByPose(const ExampleProblem& p) {
  using namespace core;
  std::map<int, ExampleStep> steps;
  for (const FactorPtr& f : p.graph) {
    int newest = 0;
    for (Key k : f->keys()) {
      if (KeySymbol(k) == 'x') newest = std::max(newest, static_cast<int>(KeyIndex(k)));
    }
    steps[newest].factors.Add(f);
  }
  std::set<Key> introduced;
  std::vector<ExampleStep> out;
  for (auto& [i, s] : steps) {
    for (const FactorPtr& f : s.factors) {
      for (Key k : f->keys()) {
        if (introduced.insert(k).second) (void)s.values.Insert(k, p.initial.Get(k));
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace slamd::testing
