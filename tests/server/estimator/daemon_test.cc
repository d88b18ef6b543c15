#include "server/estimator/daemon.h"

#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>

#include "server/ingest/conversion.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/status_t.hpp"

namespace slamd::server {
namespace {

core::NoiseModel Noise(int dim, double s) { return core::NoiseModel::Isotropic(dim, s).value(); }

slamd::odometry_t Odo(std::uint64_t from, std::uint64_t to, const std::string& robot = "r") {
  slamd::odometry_t msg;
  ToLcm(OdometryMeasurement{10, robot, from, to, core::Pose2(1, 0, 0.1), Noise(3, 0.1)}, &msg);
  return msg;
}

slamd::prior_t Prior(const std::string& robot = "r") {
  slamd::prior_t msg;
  ToLcm(PriorMeasurement{5, robot, 0, PriorKind::kPose2, core::Pose2(), Noise(3, 0.01)}, &msg);
  return msg;
}

// Collects what the daemon publishes (callbacks run on whichever thread handles the bus).
struct Client {
  explicit Client(Bus& bus) {
    subs.push_back(Subscribe<slamd::estimate_t>(
                       bus, "SLAMD_ESTIMATE",
                       [this](std::string_view, const slamd::estimate_t& m) {
                         std::lock_guard lock(mutex);
                         estimates.push_back(m);
                       },
                       nullptr)
                       .value());
    subs.push_back(Subscribe<slamd::reject_t>(
                       bus, "SLAMD_REJECT",
                       [this](std::string_view, const slamd::reject_t& m) {
                         std::lock_guard lock(mutex);
                         rejects.push_back(m);
                       },
                       nullptr)
                       .value());
    subs.push_back(Subscribe<slamd::status_t>(
                       bus, "SLAMD_STATUS",
                       [this](std::string_view, const slamd::status_t& m) {
                         std::lock_guard lock(mutex);
                         statuses.push_back(m);
                       },
                       nullptr)
                       .value());
  }
  std::mutex mutex;
  std::vector<slamd::estimate_t> estimates;
  std::vector<slamd::reject_t> rejects;
  std::vector<slamd::status_t> statuses;
  std::vector<Subscription> subs;
};

ServerParams Params() {
  ServerParams p;
  p.refine.enabled = false;
  p.publish.status_rate_hz = 0.0;
  return p;
}

TEST(DaemonTest, ManualDriveCoalescesQueuedMessagesIntoOneUpdate) {
  InProcessBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
  EXPECT_EQ(daemon->PumpIntake(0).value(), 6);
  EXPECT_EQ(daemon->queue_depth(), 6);
  EXPECT_EQ(daemon->StepEstimator(0.0), 6);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());  // delivers the estimate to the client
  ASSERT_EQ(client.estimates.size(), 1u);
  EXPECT_EQ(client.estimates[0].robot, "r");
  EXPECT_EQ(client.estimates[0].pose_index, 5);
  EXPECT_EQ(client.estimates[0].update_sequence, 1);
  EXPECT_EQ(client.estimates[0].num_values, 3);
  EXPECT_EQ(client.estimates[0].measurement_utime, 10);
  EXPECT_GE(client.estimates[0].latency_us, 0);
  EXPECT_EQ(daemon->snapshot()->counters.updates, 1);
  EXPECT_TRUE(client.rejects.empty());
}

TEST(DaemonTest, BadMessagesGetTheirRejectAndChangeNothing) {
  InProcessBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  const auto before = daemon->snapshot();

  slamd::odometry_t nan = Odo(0, 1);
  nan.values[0] = std::nan("");
  ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", nan).ok());      // stateless
  ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Prior()).ok());  // wrong type
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());     // duplicate
  slamd::remove_factor_t remove;
  ToLcm(RemoveFactorRequest{1, RemoveTarget::kOdometry, "r", 0, "", 1, 0}, &remove);
  ASSERT_TRUE(Publish(bus, "SLAMD_REMOVE_FACTOR", remove).ok());  // not implemented
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  ASSERT_EQ(client.rejects.size(), 4u);
  EXPECT_EQ(client.rejects[0].reason, slamd::reject_t::REASON_NOT_FINITE);
  EXPECT_EQ(client.rejects[0].channel, "SLAMD_ODOMETRY");
  EXPECT_EQ(client.rejects[1].reason, slamd::reject_t::REASON_DECODE_ERROR);
  EXPECT_EQ(client.rejects[2].reason, slamd::reject_t::REASON_UNKNOWN_FACTOR);
  EXPECT_EQ(client.rejects[3].reason, slamd::reject_t::REASON_DUPLICATE);
  EXPECT_EQ(client.rejects[3].channel, "SLAMD_PRIOR");
  EXPECT_EQ(client.rejects[3].robot, "r");
  const auto after = daemon->snapshot();
  EXPECT_EQ(after->num_factors, before->num_factors);
  EXPECT_EQ(after->num_variables, before->num_variables);
  EXPECT_EQ(after->update_sequence, before->update_sequence);
  EXPECT_TRUE(client.estimates.size() == 1u);  // only the first update's
}

TEST(DaemonTest, FullQueueRejectsAfterBlockingNeverDropsSilently) {
  InProcessBus bus;
  ServerParams p = Params();
  p.queue.depth = 2;
  p.queue.block_timeout_s = 0.01;
  p.publish.status_rate_hz = 1000.0;
  auto daemon = Daemon::Create(p, &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  EXPECT_EQ(daemon->queue_depth(), 2);
  EXPECT_EQ(daemon->StepEstimator(0.0), 2);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  ASSERT_EQ(client.rejects.size(), 2u);
  EXPECT_EQ(client.rejects[0].reason, slamd::reject_t::REASON_QUEUE_FULL);
  EXPECT_EQ(client.rejects[1].reason, slamd::reject_t::REASON_QUEUE_FULL);
  ASSERT_FALSE(client.statuses.empty());
  const slamd::status_t& s = client.statuses.back();
  EXPECT_EQ(s.messages_received, 4);
  EXPECT_EQ(s.messages_accepted, 2);
  EXPECT_EQ(s.messages_rejected, 2);
  EXPECT_EQ(s.rejects_by_reason[slamd::reject_t::REASON_QUEUE_FULL], 2);
  EXPECT_EQ(s.queue_capacity, 2);
  EXPECT_EQ(s.num_factors, 2);  // prior + the one odometry that was queued
  EXPECT_EQ(s.residual_dimension, 6);
}

TEST(DaemonTest, ThreadsProcessEverythingAndStopCleanly) {
  InProcessBus bus;
  ServerParams p = Params();
  p.refine.enabled = true;
  auto daemon = Daemon::Create(p, &bus).value();
  Client client(bus);
  daemon->Start();
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard lock(client.mutex);
      if (!client.estimates.empty() && client.estimates.back().pose_index == 200) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  daemon->Stop();
  std::lock_guard lock(client.mutex);
  ASSERT_FALSE(client.estimates.empty());
  EXPECT_EQ(client.estimates.back().pose_index, 200);
  EXPECT_TRUE(client.rejects.empty());
  const auto snap = daemon->snapshot();
  EXPECT_EQ(snap->counters.applied, 201);
  EXPECT_LE(snap->counters.updates, 201);  // coalesced whenever messages queued up
}

}  // namespace
}  // namespace slamd::server
