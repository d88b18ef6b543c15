// The daemon in-process on InProcessBus, driven in lock-step (one dataset step per update, the
// client waits for each estimate), against an offline Isam2 fed the same steps; and bad messages
// in the middle of the stream, which must be answered by the right reject_t and change nothing.
#include <gtest/gtest.h>

#include <cmath>

#include "core/batch/batch_solver.h"
#include "core/factors/between_factor.h"
#include "core/io/dataset_stream.h"
#include "core/isam/isam2.h"
#include "server/daemon/daemon.h"
#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "tests/testing/datasets.h"

namespace slamd::server {
namespace {

constexpr double kAnchorSigma = 1e-3;
constexpr int kSteps = 1000;

const core::BetweenFactor<core::Pose2>& Between(const core::FactorPtr& f) {
  const auto* b = dynamic_cast<const core::BetweenFactor<core::Pose2>*>(f.get());
  SLAMD_CHECK(b != nullptr) << "expected a BetweenFactor<Pose2>, got " << f->Name();
  return *b;
}

TEST(ServerInProcessTest, LockStepEstimatesEqualOfflineIsam2AndBadMessagesChangeNothing) {
  const std::string path = testing::SharedDatasetPath("input_M3500_g2o.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const core::Dataset data = core::ReadDataset(path).value();
  const std::vector<core::DatasetStep> steps = core::MakeIncrementalSteps(data);
  ASSERT_GE(steps.size(), static_cast<size_t>(kSteps));

  ServerParams params;
  params.refine.enabled = false;
  params.estimator.chi2_interval_s = 0.0;  // compared after every step
  params.publish.status_rate_hz = 0.0;
  InProcessBus bus;
  auto daemon = Daemon::Create(params, &bus).value();
  std::vector<slamd::estimate_t> estimates;
  std::vector<slamd::reject_t> rejects;
  Subscription est_sub =
      Subscribe<slamd::estimate_t>(
          bus, "SLAMD_ESTIMATE",
          [&](std::string_view, const slamd::estimate_t& m) { estimates.push_back(m); }, nullptr)
          .value();
  Subscription rej_sub =
      Subscribe<slamd::reject_t>(
          bus, "SLAMD_REJECT",
          [&](std::string_view, const slamd::reject_t& m) { rejects.push_back(m); }, nullptr)
          .value();
  std::unique_ptr<core::Isam2> offline = core::Isam2::Create(params.isam2).value();
  const std::string robot = "m3500";
  int loop_closures = 0;

  for (int k = 0; k < kSteps; ++k) {
    const core::DatasetStep& step = steps[k];
    // Offline: the step as PrepareStep makes it, with the odometry factor first (the order the
    // server adds factors in: it needs the new pose before the loop closures that use it).
    core::FactorGraph prepared, factors;
    core::Values values;
    core::PrepareStep(
        step, [&](core::Key key) { return offline->CalculateEstimate(key); }, &prepared, &values);
    if (step.odometry) factors.Add(step.odometry);
    for (const core::FactorPtr& f : prepared.factors()) {
      if (f != step.odometry) factors.Add(f);
    }
    if (k == 0) {
      ASSERT_TRUE(core::AddGaugePrior(values, step.pose, kAnchorSigma, &factors).ok());
    }

    // Online: the same step as messages.
    if (k == 0) {
      slamd::prior_t prior;
      ToLcm(PriorMeasurement{1, robot, core::KeyIndex(step.pose), PriorKind::kPose2,
                             std::get<core::Pose2>(step.initial),
                             core::NoiseModel::Isotropic(3, kAnchorSigma).value()},
            &prior);
      ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", prior).ok());
    }
    for (const core::FactorPtr& f : factors.factors()) {
      if (f->keys().size() == 1) continue;  // the gauge prior, sent above
      const auto& b = Between(f);
      const std::uint64_t i = core::KeyIndex(f->keys()[0]), j = core::KeyIndex(f->keys()[1]);
      if (f == step.odometry) {
        ASSERT_EQ(f->keys()[1], step.pose) << "reversed odometry is not streamed by this test";
        slamd::odometry_t odo;
        ToLcm(OdometryMeasurement{k, robot, i, j, b.measured(), b.noise_model()}, &odo);
        ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
      } else {
        slamd::loop_closure_t lc;
        ToLcm(LoopClosureMeasurement{k, robot, i, robot, j, b.measured(), b.noise_model(), {}},
              &lc);
        ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
        ++loop_closures;
      }
    }
    // Every 50 steps, bad messages after the step's own: each must give its reject_t only.
    int bad = 0;
    if (k > 0 && k % 50 == 0) {
      slamd::odometry_t dup;  // another odometry between the poses just joined
      const auto& b = Between(step.odometry);
      ToLcm(OdometryMeasurement{k, robot, core::KeyIndex(step.odometry_from),
                                core::KeyIndex(step.pose), b.measured() * core::Pose2(0.5, 0, 0),
                                b.noise_model()},
            &dup);
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", dup).ok());
      slamd::odometry_t asym = dup;  // non-symmetric covariance
      asym.from_index = 100000;
      asym.to_index = 100001;
      asym.covariance[1] += 1.0;
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", asym).ok());
      slamd::loop_closure_t spatial;  // a 3D measurement between 2D poses
      ToLcm(LoopClosureMeasurement{k,
                                   robot,
                                   0,
                                   robot,
                                   1,
                                   core::Pose3(),
                                   core::NoiseModel::Isotropic(6, 0.1).value(),
                                   {}},
            &spatial);
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", spatial).ok());
      slamd::loop_closure_t stranger = spatial;  // from a robot nobody knows
      stranger.robot_a = "nobody";
      stranger.robot_b = "noone";
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", stranger).ok());
      bad = 4;
    }

    // Lock-step: deliver, one update, deliver the estimate.
    ASSERT_TRUE(daemon->PumpIntake(0).ok());
    ASSERT_GT(daemon->StepEstimator(0.0), 0);
    estimates.clear();
    ASSERT_TRUE(daemon->PumpIntake(0).ok());
    const core::Isam2Result r = offline->Update(factors, values);
    ASSERT_TRUE(r.status.ok()) << r.status.ToString();

    ASSERT_EQ(static_cast<int>(rejects.size()), (k / 50) * 4) << "step " << k;
    if (bad > 0) {
      const size_t n = rejects.size();
      // Stateless rejects are published by the intake, before the estimator's stateful ones.
      EXPECT_EQ(rejects[n - 4].reason, slamd::reject_t::REASON_COVARIANCE_NOT_SYMMETRIC);
      EXPECT_EQ(rejects[n - 3].reason, slamd::reject_t::REASON_DUPLICATE);
      EXPECT_EQ(rejects[n - 2].reason, slamd::reject_t::REASON_BAD_MEASUREMENT);
      EXPECT_EQ(rejects[n - 1].reason, slamd::reject_t::REASON_UNKNOWN_ROBOT);
      EXPECT_EQ(rejects[n - 1].robot, "nobody");
    }
    ASSERT_EQ(estimates.size(), 1u) << "step " << k;
    const slamd::estimate_t& e = estimates[0];
    EXPECT_EQ(e.robot, robot);
    EXPECT_EQ(e.update_sequence, k + 1);
    ASSERT_EQ(static_cast<std::uint64_t>(e.pose_index), core::KeyIndex(step.pose));
    const core::Pose2 want = std::get<core::Pose2>(offline->CalculateEstimate(step.pose));
    ASSERT_EQ(e.num_values, 3);
    EXPECT_NEAR(e.values[0], want.x(), 1e-9) << "step " << k;
    EXPECT_NEAR(e.values[1], want.y(), 1e-9) << "step " << k;
    EXPECT_NEAR(std::remainder(e.values[2] - want.theta(), 2 * M_PI), 0.0, 1e-9) << "step " << k;
  }
  EXPECT_GT(loop_closures, 10);
  const auto snap = daemon->snapshot();
  EXPECT_EQ(snap->counters.updates, kSteps);
  EXPECT_NEAR(snap->chi2, offline->Chi2(), 1e-9 * std::max(1.0, offline->Chi2()));
  EXPECT_EQ(snap->num_factors, static_cast<std::int64_t>(offline->Factors().size()));
}

}  // namespace
}  // namespace slamd::server
