// Lock-step over udpm:// (ttl=0, private network namespace): a client streams
// all of input_M3500 into the real `slamd` (refinement off, and background relinearisation: its
// swaps come when a helper thread is done), one step per pose, waiting for each
// pose's estimate_t before the next step; every published estimate must equal offline Isam2 fed
// the same updates to 1e-9.
//
// "The same updates": slamd folds whatever is queued into one update, and over UDP a step's loop
// closures often reach its queue just after the estimator took the step's odometry (they then go
// into the next update, with the next step's messages or alone). The journal records which
// messages went into which update, so the offline reference is built from it: each message's
// measurement and noise as decoded from the wire (neither the covariance a message carries nor a
// Pose2 sent as x, y, theta is bit-identical to the dataset's, and over 3500 steps that
// round-off grows to ~1e-9), each new pose predicted through its odometry from the current
// estimate of its predecessor (the bench protocol), grouped as slamd grouped them. The test
// prints how many updates were not exactly one step.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/isam/isam2.h"
#include "server/config/config_loader.h"
#include "server/journal/journal.h"
#include "server/journal/read_journal.h"
#include "server/messages/inbound.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/datasets.h"
#include "tests/testing/processes.h"
#include "tests/testing/wire_steps.h"

namespace slamd::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
constexpr const char* kRobot = "m3500";
constexpr double kAnchorSigma = 1e-3;  // the bench protocol's anchor
constexpr const char* kConfig =
    "refine { enabled: false }\n"
    "estimator { background_relinearization_above: 0 }\n"
    "publish { status_rate_hz: 5 estimate_covariance: false }\n"
    "journal { sync: NEVER snapshot_every_updates: 0 snapshot_every_s: 0 }\n"
    "log_level: \"warn\"\n";

template <typename Msg>
Msg Decode(const std::vector<std::uint8_t>& bytes) {
  Msg m;
  SLAMD_CHECK(m.decode(bytes.data(), 0, static_cast<int>(bytes.size())) ==
              static_cast<int>(bytes.size()));
  return m;
}

// What slamd makes of a message of this test: its measurement and factor (keys from the dataset
// factor it carries; the anchoring prior on `anchor`).
struct Received {
  core::Pose2 measured;
  core::FactorPtr factor;
};
Received AsReceived(const testing::WireMessage& w, core::Key anchor) {
  if (w.suffix == "PRIOR") {
    const PriorMeasurement p = Convert(Decode<slamd::prior_t>(w.bytes)).value();
    const core::Pose2 z = std::get<core::Pose2>(p.measured);
    return {z, std::make_shared<core::PriorFactor<core::Pose2>>(anchor, z, p.noise)};
  }
  const core::Key a = w.factor->keys()[0], b = w.factor->keys()[1];
  auto between = [&](const RelativePose& z, const core::NoiseModel& noise) {
    const core::Pose2 z2 = std::get<core::Pose2>(z);
    return Received{z2, std::make_shared<core::BetweenFactor<core::Pose2>>(a, b, z2, noise)};
  };
  if (w.suffix == "ODOMETRY") {
    const OdometryMeasurement o = Convert(Decode<slamd::odometry_t>(w.bytes)).value();
    return between(o.measured, o.noise);
  }
  const LoopClosureMeasurement l = Convert(Decode<slamd::loop_closure_t>(w.bytes)).value();
  return between(l.measured, l.noise);
}

// Where a journaled message came from: step and position in the step.
struct Origin {
  int step = 0;
  int index = 0;
  std::int64_t sequence = 0;  // journal message sequence
};

TEST(ServerLockstepNetnsTest, PublishedEstimatesEqualOfflineIsam2UpdateByUpdate) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  const std::string path = testing::SharedDatasetPath("input_M3500_g2o.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const std::vector<core::DatasetStep> steps =
      core::MakeIncrementalSteps(core::ReadDataset(path).value());
  const int n = static_cast<int>(steps.size());
  int num_factors = 0;
  const std::vector<testing::StepMessages> messages =
      testing::MakeWireSteps(steps, n, kRobot, kAnchorSigma, &num_factors);

  const fs::path dir = fs::temp_directory_path() / ("slamd_lockstep_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "data");
  const std::string config = (dir / "slamd.textproto").string();
  std::ofstream(config) << kConfig;

  auto bus = LcmBus::Create(LcmBusParams{.url = kUrl}).value();
  std::map<std::int64_t, std::vector<slamd::estimate_t>> estimates;  // by update_sequence
  std::vector<bool> estimated(n, false);
  bool status_seen = false;
  Subscription est_sub = Subscribe<slamd::estimate_t>(
                             *bus, "SLAMD_ESTIMATE",
                             [&](std::string_view, const slamd::estimate_t& m) {
                               estimates[m.update_sequence].push_back(m);
                               if (m.pose_index >= 0 && m.pose_index < n) {
                                 estimated[m.pose_index] = true;
                               }
                             },
                             nullptr)
                             .value();
  Subscription status_sub =
      Subscribe<slamd::status_t>(
          *bus, "SLAMD_STATUS",
          [&](std::string_view, const slamd::status_t&) { status_seen = true; }, nullptr)
          .value();
  auto pump_until = [&](const auto& done, double timeout_s) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (!done()) {
      if (Clock::now() > deadline || !bus->HandleOnce(20).ok()) return false;
    }
    return true;
  };

  const std::string log = (dir / "slamd.log").string();
  const pid_t pid = testing::Spawn(
      {SLAMD_PATH, "--config", config, "--lcm-url", kUrl, "--data-dir", (dir / "data").string()},
      log, testing::Streams::kStdoutAndStderr);
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(pump_until([&] { return status_seen; }, 30.0)) << "slamd did not start: " << log;

  const auto t0 = Clock::now();
  for (int k = 0; k < n; ++k) {
    for (const testing::WireMessage& m : messages[k]) {
      ASSERT_TRUE(bus->Publish(std::string("SLAMD_") + m.suffix, m.bytes).ok());
    }
    ASSERT_TRUE(pump_until([&] { return estimated[k]; }, 20.0)) << "no estimate of pose " << k;
  }
  const double stream_s = std::chrono::duration<double>(Clock::now() - t0).count();
  (void)bus->HandleOnce(100);  // a last split-off update's estimate, if any
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  ASSERT_EQ(testing::WaitExit(pid), 0) << "slamd did not stop cleanly: " << log;

  // Which messages went into which update, from the journal.
  std::map<std::string, Origin> origin;
  for (int k = 0; k < n; ++k) {
    for (int i = 0; i < static_cast<int>(messages[k].size()); ++i) {
      const auto& b = messages[k][i].bytes;
      origin[std::string(b.begin(), b.end())] = {k, i};
    }
  }
  const core::Result<JournalContents> journal = ReadJournal((dir / "data").string());
  ASSERT_TRUE(journal.ok()) << journal.status().ToString();

  const ServerParams params = LoadConfigFile(config).value();
  std::unique_ptr<core::Isam2> offline = core::Isam2::Create(params.isam2).value();
  std::vector<Origin> journaled;  // not yet in an update (intake journals ahead of updates)
  int updates = 0, not_one_step = 0, compared = 0;
  double worst = 0.0;
  for (const journal::JournalRecord& r : journal.value().records) {
    if (r.has_message()) {
      const auto it = origin.find(r.message().lcm_payload());
      ASSERT_NE(it, origin.end()) << "journaled message " << r.message().sequence()
                                  << " was not sent by this test";
      journaled.push_back(it->second);
      journaled.back().sequence = r.message().sequence();
      continue;
    }
    if (!r.has_boundary()) continue;
    const journal::UpdateBoundary& b = r.boundary();
    std::vector<Origin> pending;
    while (!journaled.empty() && journaled.front().sequence <= b.last_message_sequence()) {
      pending.push_back(journaled.front());
      journaled.erase(journaled.begin());
    }
    ASSERT_EQ(b.message_count(), static_cast<int>(pending.size()))
        << "update " << b.update_sequence();
    ASSERT_EQ(b.update_sequence(), ++updates);
    const bool one_step = pending.size() == messages[pending.front().step].size() &&
                          pending.front().step == pending.back().step;
    if (!one_step) ++not_one_step;

    // The update offline: the messages' factors in journal order; each odometry's new pose
    // predicted as the bench protocol does, from the estimate (or this update's own guess) of
    // its predecessor.
    core::FactorGraph factors;
    core::Values values;
    for (const Origin& o : pending) {
      const core::DatasetStep& step = steps[o.step];
      const testing::WireMessage& m = messages[o.step][o.index];
      const Received r = AsReceived(m, step.pose);
      if (m.factor == nullptr) {  // the anchoring prior of step 0, which places its pose
        ASSERT_TRUE(values.Insert(step.pose, r.measured).ok());
      } else if (m.factor == step.odometry) {
        const core::Key from = step.odometry_from;
        const core::Pose2 a = std::get<core::Pose2>(
            values.Contains(from) ? values.Get(from) : offline->CalculateEstimate(from));
        ASSERT_TRUE(values.Insert(step.pose, a * r.measured).ok());
      }
      factors.Add(r.factor);
    }
    const core::Isam2Result u = offline->Update(factors, values);
    ASSERT_TRUE(u.status.ok()) << u.status.ToString();

    for (const slamd::estimate_t& e : estimates[b.update_sequence()]) {
      ASSERT_EQ(e.num_values, 3);
      ASSERT_TRUE(e.pose_index >= 0 && e.pose_index < n);
      ASSERT_EQ(core::KeyIndex(steps[e.pose_index].pose), static_cast<std::uint64_t>(e.pose_index));
      const core::Pose2 want =
          std::get<core::Pose2>(offline->CalculateEstimate(steps[e.pose_index].pose));
      const double d = std::max({std::abs(e.values[0] - want.x()), std::abs(e.values[1] - want.y()),
                                 std::abs(std::remainder(e.values[2] - want.theta(), 2 * M_PI))});
      worst = std::max(worst, d);
      EXPECT_LE(d, 1e-9) << "pose " << e.pose_index << " after update " << b.update_sequence();
      ++compared;
    }
  }
  std::printf(
      "[ lockstep ] %d steps streamed in %.1f s; %d updates (%d not exactly one step); %d "
      "estimates compared, largest difference %.3g\n",
      n, stream_s, updates, not_one_step, compared, worst);
  EXPECT_TRUE(journaled.empty()) << "messages journaled but never in an update";
  EXPECT_EQ(static_cast<int>(offline->Factors().size()), num_factors);
  EXPECT_GE(compared, n);
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace slamd::server
