// Oracles shared by the solver tests: how far apart two estimates are, and the exact
// Gauss-Newton step of a whole graph at a linearisation point (what Isam2 must reproduce).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>

#include "core/batch/normal_equations.h"
#include "core/factors/factor_graph.h"

namespace slamd::testing {

// The largest tangent-space distance between the same variable in `a` and `b` (keys of `a`).
inline double MaxDifference(const core::Values& a, const core::Values& b) {
  double worst = 0.0;
  for (core::Key key : a.keys()) {
    worst = std::max(worst, core::LocalCoordinates(a.Get(key), b.Get(key)).norm());
  }
  return worst;
}

// θ ⊕ δ with δ the exact solution of `graph` linearised at θ (sparse Cholesky of the whole
// normal equations).
inline core::Values BatchStepAt(const core::FactorGraph& graph, const core::Values& theta) {
  auto eq = core::internal::NormalEquations::Create(graph, theta);
  EXPECT_TRUE(eq.ok()) << eq.status().ToString();
  core::Values out = theta;
  if (!eq.ok()) return out;
  (*eq)->Linearize(theta);
  Eigen::VectorXd delta;
  const core::Status solved = (*eq)->Solve(&delta);
  EXPECT_TRUE(solved.ok()) << solved.ToString();
  if (solved.ok()) (*eq)->RetractAll(theta, delta, &out);
  return out;
}

}  // namespace slamd::testing
