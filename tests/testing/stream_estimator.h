// Test helper: messages as slamctl makes them (clients/slamctl/dataset_messages.h) fed to an
// in-process estimator image by image, and the batch optimum of the graph it ends with: the
// reference a live server's settled estimate is checked against.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <variant>
#include <vector>

#include "clients/slamctl/dataset_messages.h"
#include "core/batch/batch_solver.h"
#include "server/estimator/estimator.h"

namespace slamd::testing {

struct StreamedEstimator {
  std::unique_ptr<server::Estimator> estimator;
  std::vector<server::Rejection> rejections;
  int features = 0;  // frame features sent
};

// One Process per step; every message must convert (stateless validation).
inline StreamedEstimator StreamSteps(const std::vector<clients::StepMessages>& steps,
                                     const core::Isam2Params& isam2 = {}) {
  StreamedEstimator s{server::Estimator::Create({.chi2_interval_s = 0.0}, isam2).value(), {}, 0};
  for (const clients::StepMessages& step : steps) {
    std::vector<server::Inbound> batch;
    for (const clients::RobotMessage& m : step.messages) {
      if (const auto* f = std::get_if<slamd::frame_observations_t>(&m)) {
        s.features += f->num_features;
      }
      std::visit(
          [&](const auto& lcm) {
            auto value = server::Convert(lcm);
            EXPECT_TRUE(value.ok()) << value.verdict().message;
            if (value.ok()) batch.push_back({.measurement = std::move(value).value()});
          },
          m);
    }
    server::ProcessResult r = s.estimator->Process(std::move(batch));
    EXPECT_TRUE(r.status.ok()) << r.status.ToString();
    for (server::Rejection& j : r.rejections) s.rejections.push_back(std::move(j));
  }
  return s;
}

// The batch optimum's chi2 of the estimator's graph (Levenberg-Marquardt from its estimate).
inline double BatchOptimumChi2(const server::Estimator& e) {
  const server::EstimatorState state = e.ExportState();
  core::FactorGraph graph;
  for (const core::FactorPtr& f : state.factors) graph.Add(f);
  const core::BatchResult batch = core::Optimize(graph, e.solver().CalculateEstimate());
  EXPECT_TRUE(batch.status.ok()) << batch.status.ToString();
  return batch.summary.final_chi2;
}

}  // namespace slamd::testing
