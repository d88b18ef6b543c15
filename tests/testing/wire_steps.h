// A 2D pose-graph dataset as the LCM messages a robot would send slamd, step by step (one step
// per new pose, as core::MakeIncrementalSteps makes them): step 0 an anchoring prior_t, then
// each step's odometry_t first and its loop_closure_t's. For integration tests that stream a
// dataset into the real daemon and compare with offline solvers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/base/check.h"
#include "core/factors/between_factor.h"
#include "core/io/dataset_stream.h"
#include "server/messages/inbound.h"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "tests/testing/datasets.h"

namespace slamd::testing {

// One inbound message as it goes on the wire, and the dataset factor it carries (null for the
// anchoring prior).
struct WireMessage {
  std::string suffix;  // channel without the prefix
  std::vector<std::uint8_t> bytes;
  core::FactorPtr factor = nullptr;
};
using StepMessages = std::vector<WireMessage>;

template <typename Msg>
WireMessage Wire(const char* suffix, const Msg& m, core::FactorPtr factor) {
  WireMessage w{suffix, std::vector<std::uint8_t>(m.getEncodedSize()), std::move(factor)};
  m.encode(w.bytes.data(), 0, static_cast<int>(w.bytes.size()));
  return w;
}

inline const core::BetweenFactor<core::Pose2>& Between2(const core::FactorPtr& f) {
  const auto* b = dynamic_cast<const core::BetweenFactor<core::Pose2>*>(f.get());
  SLAMD_CHECK(b != nullptr) << "expected a BetweenFactor<Pose2>, got " << f->Name();
  return *b;
}

// Steps 0..n-1 of a 2D pose graph as messages of `robot` (utime = step index); the prior has
// sigma `anchor_sigma` on every axis. *factors gets the number of factors they carry.
inline std::vector<StepMessages> MakeWireSteps(const std::vector<core::DatasetStep>& steps, int n,
                                               const std::string& robot, double anchor_sigma,
                                               int* factors) {
  using server::LoopClosureMeasurement;
  using server::OdometryMeasurement;
  using server::PriorKind;
  using server::PriorMeasurement;
  std::vector<StepMessages> out(n);
  *factors = 1;  // the prior
  for (int k = 0; k < n; ++k) {
    const core::DatasetStep& step = steps[k];
    if (k == 0) {
      slamd::prior_t prior;
      server::ToLcm(PriorMeasurement{k, robot, core::KeyIndex(step.pose), PriorKind::kPose2,
                                     std::get<core::Pose2>(step.initial),
                                     core::NoiseModel::Isotropic(3, anchor_sigma).value()},
                    &prior);
      out[k].push_back(Wire("PRIOR", prior, nullptr));
    }
    if (step.odometry) {
      const auto& b = Between2(step.odometry);
      SLAMD_CHECK(step.odometry->keys()[1] == step.pose) << "reversed odometry at step " << k;
      slamd::odometry_t odo;
      server::ToLcm(OdometryMeasurement{k, robot, core::KeyIndex(step.odometry_from),
                                        core::KeyIndex(step.pose), b.measured(), b.noise_model()},
                    &odo);
      out[k].push_back(Wire("ODOMETRY", odo, step.odometry));
      ++*factors;
    }
    for (const core::FactorPtr& f : step.factors) {
      if (f == step.odometry) continue;
      const auto& b = Between2(f);
      slamd::loop_closure_t lc;
      server::ToLcm(LoopClosureMeasurement{k,
                                           robot,
                                           core::KeyIndex(f->keys()[0]),
                                           robot,
                                           core::KeyIndex(f->keys()[1]),
                                           b.measured(),
                                           b.noise_model(),
                                           {}},
                    &lc);
      out[k].push_back(Wire("LOOP_CLOSURE", lc, f));
      ++*factors;
    }
  }
  return out;
}

// A shared dataset (../shared/datasets/`file`) as a robot streams it: its incremental steps, the
// messages of steps 0..n-1 (MakeWireSteps, anchor sigma 1e-3) and the factors they carry. The
// calling test is skipped when the dataset is missing (check ::testing::Test::IsSkipped()).
struct WireDataset {
  std::vector<core::DatasetStep> steps;
  std::vector<StepMessages> messages;
  int factors = 0;
};
inline void LoadWireDataset(const std::string& file, int n, const std::string& robot,
                            WireDataset* out) {
  const std::string path = SharedDatasetPath(file);
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  out->steps = core::MakeIncrementalSteps(core::ReadDataset(path).value());
  out->messages = MakeWireSteps(out->steps, n, robot, 1e-3, &out->factors);
}

}  // namespace slamd::testing
