// Two robots in one world, driven through the daemon (in-process bus, manual drive with random
// coalescing and idle refinement): robot "b" has no prior, so it is held until the first
// inter-robot loop closure ties it to robot "a"; after that both are estimated jointly. Once
// settled, the estimate equals the batch optimum (core/batch LM from an independent initial
// guess) of the same factors.
#include <gtest/gtest.h>

#include <random>

#include "core/batch/batch_solver.h"
#include "server/daemon/daemon.h"
#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"

namespace slamd::server {
namespace {

using core::Pose2;

core::NoiseModel Noise(int dim, double s) { return core::NoiseModel::Isotropic(dim, s).value(); }

TEST(ServerTwoRobotsTest, HeldRobotJoinsAndBothConvergeToTheJointBatchOptimum) {
  constexpr int kPoses = 60;
  ServerParams params;
  params.publish.status_rate_hz = 0.0;
  params.isam2.refine_threshold = 1e-10;
  params.refine.idle_s = 0.0;  // manual drive: refine whenever the queue is empty
  InProcessBus bus;
  auto daemon = Daemon::Create(params, &bus).value();
  std::vector<slamd::reject_t> rejects;
  Subscription sub =
      Subscribe<slamd::reject_t>(
          bus, "SLAMD_REJECT",
          [&](std::string_view, const slamd::reject_t& m) { rejects.push_back(m); }, nullptr)
          .value();

  // Ground truth: two circles, b's shifted by (3, 1); noisy relative measurements of it.
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0.0, 0.03);
  const auto truth = [](int robot, int i) {
    const double t = 2 * M_PI * i / 30.0;
    const Pose2 on_circle(5 * std::sin(t), 5 - 5 * std::cos(t), t);
    return robot == 0 ? on_circle : Pose2(3, 1, 0.2) * on_circle;
  };
  const auto noisy = [&](const Pose2& z) {
    return Pose2(z.x() + noise(rng), z.y() + noise(rng), z.theta() + noise(rng));
  };
  slamd::prior_t prior;
  ToLcm(PriorMeasurement{1, "a", 0, PriorKind::kPose2, truth(0, 0), Noise(3, 0.01)}, &prior);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", prior).ok());
  int inter = 0;
  for (int i = 0; i + 1 < kPoses; ++i) {
    for (int r = 0; r < 2; ++r) {
      slamd::odometry_t odo;
      const Pose2 z = noisy(truth(r, i).Inverse() * truth(r, i + 1));
      ToLcm(OdometryMeasurement{i, r == 0 ? "a" : "b", static_cast<std::uint64_t>(i),
                                static_cast<std::uint64_t>(i + 1), z, Noise(3, 0.03)},
            &odo);
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
    }
    if (i >= 8 && i % 6 == 2) {  // inter-robot and intra-robot loop closures
      slamd::loop_closure_t lc;
      const int j = i - 5;
      ToLcm(LoopClosureMeasurement{i,
                                   "a",
                                   static_cast<std::uint64_t>(i + 1),
                                   "b",
                                   static_cast<std::uint64_t>(j),
                                   noisy(truth(0, i + 1).Inverse() * truth(1, j)),
                                   Noise(3, 0.05),
                                   {}},
            &lc);
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
      ++inter;
      if (i + 1 >= 30) {
        ToLcm(LoopClosureMeasurement{i,
                                     "b",
                                     static_cast<std::uint64_t>(i + 1),
                                     "b",
                                     static_cast<std::uint64_t>(i + 1 - 30),
                                     noisy(truth(1, i + 1).Inverse() * truth(1, i + 1 - 30)),
                                     Noise(3, 0.05),
                                     {}},
              &lc);
        ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
      }
    }
    if (rng() % 3 == 0) {  // deliver now and then: coalesced updates of varying size
      ASSERT_TRUE(daemon->PumpIntake(0).ok());
      daemon->StepEstimator(0.0);
    }
  }
  ASSERT_GE(inter, 5);
  for (int k = 0; k < 10000 && (daemon->queue_depth() > 0 || !daemon->snapshot()->settled); ++k) {
    ASSERT_TRUE(daemon->PumpIntake(0).ok());
    daemon->StepEstimator(0.0);
  }
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  EXPECT_TRUE(rejects.empty()) << rejects.front().detail;
  const auto snap = daemon->snapshot();
  ASSERT_TRUE(snap->settled);
  ASSERT_EQ(snap->robots.size(), 2u);
  EXPECT_EQ(snap->num_variables, 2 * kPoses);
  EXPECT_EQ(snap->robots[1].name, "b");
  EXPECT_EQ(snap->robots[1].pose_index, static_cast<std::uint64_t>(kPoses - 1));

  // The joint batch optimum of the same factors, from a guess made of the truth plus a bias.
  const core::Isam2& solver = daemon->estimator_for_tests().solver();
  const core::FactorGraph graph = solver.Factors();
  const core::Values online = solver.CalculateEstimate();
  core::Values guess;
  for (core::Key k : online.keys()) {
    const int robot = core::KeyRobot(k) == core::KeyRobot(online.keys()[0]) ? 0 : 1;
    const Pose2 t = truth(robot, static_cast<int>(core::KeyIndex(k)));
    ASSERT_TRUE(guess.Insert(k, Pose2(t.x() + 0.3, t.y() - 0.2, t.theta() + 0.05)).ok());
  }
  core::BatchParams batch;
  batch.relative_tolerance = 1e-14;
  batch.absolute_tolerance = 1e-14;
  const core::BatchResult optimum = core::Optimize(graph, guess, batch);
  ASSERT_TRUE(optimum.status.ok()) << optimum.status.ToString();
  for (core::Key k : online.keys()) {
    EXPECT_LT(
        core::LocalCoordinates(online.Get(k), optimum.values.Get(k)).lpNorm<Eigen::Infinity>(),
        1e-7)
        << core::KeyToString(k);
  }
  EXPECT_NEAR(snap->chi2, graph.Chi2(optimum.values), 1e-8 * graph.Chi2(optimum.values));
}

}  // namespace
}  // namespace slamd::server
