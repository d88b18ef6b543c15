// The real `slamd` executable over UDP multicast (udpm://, ttl=0), inside a private network
// namespace made by scripts/netns-run (ctest label netns; skipped with 77 where none can be made).
// A client streams a prior and odometry, plus one bad message, waits for the estimate of the last
// pose and the reject_t, then sends SIGTERM: slamd must exit 0.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <string>

#include "server/messages/inbound.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"

namespace slamd::server {
namespace {

using testing::OnlyLoopback;
using testing::Spawn;
using testing::WaitExit;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";

TEST(ServerUdpmNetnsTest, StreamsEstimatesRejectsAndStopsOnSigterm) {
  ASSERT_TRUE(OnlyLoopback()) << testing::kNotInNetns;
  const std::string config = testing::WriteTempFile(
      "slamd_udpm_netns_test.textproto",
      "refine { enabled: false }\npublish { status_rate_hz: 10 }\nlog_level: \"warn\"\n");
  auto bus = LcmBus::Create(LcmBusParams{.url = kUrl}).value();
  std::vector<slamd::estimate_t> estimates;
  std::vector<slamd::reject_t> rejects;
  Subscription s1 =
      Subscribe<slamd::estimate_t>(
          *bus, "UT_ESTIMATE",
          [&](std::string_view, const slamd::estimate_t& m) { estimates.push_back(m); }, nullptr)
          .value();
  Subscription s2 =
      Subscribe<slamd::reject_t>(
          *bus, "UT_REJECT",
          [&](std::string_view, const slamd::reject_t& m) { rejects.push_back(m); }, nullptr)
          .value();

  const pid_t pid =
      Spawn({SLAMD_PATH, "--config", config, "--lcm-url", kUrl, "--channel-prefix", "UT_"});
  ASSERT_GE(pid, 0);
  // slamd subscribes before its threads start, so its first status_t means it is listening.
  bool listening = false;
  Subscription s3 =
      Subscribe<slamd::status_t>(
          *bus, "UT_STATUS", [&](std::string_view, const slamd::status_t&) { listening = true; },
          nullptr)
          .value();
  const auto start_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!listening && std::chrono::steady_clock::now() < start_deadline) {
    ASSERT_TRUE(bus->HandleOnce(50).ok());
  }
  ASSERT_TRUE(listening) << "no status_t from slamd";

  const core::NoiseModel noise = core::NoiseModel::Isotropic(3, 0.1).value();
  slamd::prior_t prior;
  ToLcm(PriorMeasurement{1, "bot", 0, PriorKind::kPose2, core::Pose2(), noise}, &prior);
  ASSERT_TRUE(Publish(*bus, "UT_PRIOR", prior).ok());
  constexpr int kPoses = 20;
  for (int i = 0; i < kPoses; ++i) {
    slamd::odometry_t odo;
    ToLcm(OdometryMeasurement{i, "bot", std::uint64_t(i), std::uint64_t(i + 1),
                              core::Pose2(1.0, 0.0, 0.1), noise},
          &odo);
    ASSERT_TRUE(Publish(*bus, "UT_ODOMETRY", odo).ok());
  }
  slamd::odometry_t bad;
  ToLcm(OdometryMeasurement{99, "bot", 5, 6, core::Pose2(1.5, 0.0, 0.1), noise}, &bad);
  ASSERT_TRUE(Publish(*bus, "UT_ODOMETRY", bad).ok());  // another odometry 5 -> 6

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline &&
         (rejects.empty() || estimates.empty() || estimates.back().pose_index != kPoses)) {
    ASSERT_TRUE(bus->HandleOnce(50).ok());
  }
  kill(pid, SIGTERM);
  EXPECT_EQ(WaitExit(pid), 0);

  ASSERT_FALSE(estimates.empty());
  const slamd::estimate_t& last = estimates.back();
  EXPECT_EQ(last.pose_index, kPoses);
  // The chain's optimum is the composition of the odometry.
  core::Pose2 want;
  for (int i = 0; i < kPoses; ++i) want = want * core::Pose2(1.0, 0.0, 0.1);
  EXPECT_NEAR(last.values[0], want.x(), 1e-6);
  EXPECT_NEAR(last.values[1], want.y(), 1e-6);
  ASSERT_EQ(rejects.size(), 1u);
  EXPECT_EQ(rejects[0].reason, slamd::reject_t::REASON_DUPLICATE);
  EXPECT_EQ(rejects[0].message_utime, 99);
}

}  // namespace
}  // namespace slamd::server
