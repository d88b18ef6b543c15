// Helpers of the daemon's recovery tests (recovery_test.cc, lifelong_recovery_test.cc): a
// temporary data directory, test params, synthetic streams driven by hand, and state checks.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "server/daemon/daemon.h"
#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "tests/testing/noise.h"

namespace slamd::server::recovery_test {

namespace fs = std::filesystem;

using testing::Noise;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("slamd_recovery_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
    fs::remove_all(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string str() const { return path_.string(); }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

inline ServerParams Params(const std::string& dir) {
  ServerParams p;
  p.data_dir = dir;
  p.refine.enabled = true;
  p.refine.budget_s = 0.001;
  p.refine.idle_s = 0.0;  // manual drive: refine whenever the queue is empty
  p.publish.status_rate_hz = 0.0;
  p.journal.sync = SyncPolicy::kNever;  // tests need no fsync; the policies are tested in journal/
  p.journal.snapshot_every_updates = 0;
  p.journal.snapshot_every_s = 0;
  return p;
}

// The robot's first pose, at the origin.
inline void SendAnchor(Bus& bus) {
  slamd::prior_t prior;
  ToLcm(PriorMeasurement{1, "r", 0, PriorKind::kPose2, core::Pose2(), Noise(3, 0.01)}, &prior);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", prior).ok());
}

// A loop-y 2D trajectory as messages: prior, odometry, a loop closure every 10 poses, and a
// duplicate now and then (rejected, but journaled: it was accepted at intake).
inline void Send(Bus& bus, int from, int to) {
  std::mt19937 rng(from);
  std::normal_distribution<double> n(0.0, 0.05);
  if (from == 0) SendAnchor(bus);
  for (int i = from; i < to; ++i) {
    slamd::odometry_t odo;
    ToLcm(OdometryMeasurement{i, "r", static_cast<std::uint64_t>(i),
                              static_cast<std::uint64_t>(i + 1),
                              core::Pose2(1 + n(rng), n(rng), 0.3 + n(rng)), Noise(3, 0.05)},
          &odo);
    ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
    if (i % 7 == 3) {
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());  // duplicate
    }
    if (i >= 20 && i % 10 == 0) {
      slamd::loop_closure_t lc;
      ToLcm(LoopClosureMeasurement{i,
                                   "r",
                                   static_cast<std::uint64_t>(i + 1),
                                   "r",
                                   static_cast<std::uint64_t>(i - 20),
                                   core::Pose2(0.4 + n(rng), -0.3, 1.0 + n(rng)),
                                   Noise(3, 0.1),
                                   {}},
            &lc);
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
    }
  }
}

// Delivers everything published, in small random batches (as a live server coalesces), with
// refinement steps in between.
inline void Drive(Daemon& d, std::mt19937& rng) {
  for (int guard = 0; guard < 10000; ++guard) {
    const int n = d.PumpIntake(0).value();
    if (n == 0 && d.queue_depth() == 0) break;
    d.StepEstimator(0.0);
    if (rng() % 3 == 0) d.StepEstimator(0.0);  // idle: a refinement step
  }
}

// Sends poses from..to in chunks of 1..6 poses, each driven through (so updates are many and
// of varying size, as a live server's coalescing makes them).
inline void Stream(Bus& bus, Daemon& d, int from, int to, std::mt19937& rng) {
  for (int k = from; k < to;) {
    const int next = std::min(to, k + 1 + static_cast<int>(rng() % 6));
    Send(bus, k, next);
    Drive(d, rng);
    k = next;
  }
}

// Every reject_t the daemon publishes, appended to *out.
inline Subscription CollectRejects(Bus& bus, std::vector<slamd::reject_t>* out) {
  return Subscribe<slamd::reject_t>(
             bus, "SLAMD_REJECT",
             [out](std::string_view, const slamd::reject_t& m) { out->push_back(m); }, nullptr)
      .value();
}

// A data directory holding the journal of `poses` poses streamed through a daemon.
inline void RecordSession(const TempDir& dir, int poses, unsigned seed) {
  InProcessBus bus;
  std::mt19937 rng(seed);
  auto d = Daemon::Create(Params(dir.str()), &bus).value();
  Stream(bus, *d, 0, poses, rng);
}

inline core::Values Estimate(const Daemon& d) {
  return d.estimator_for_tests().solver().CalculateEstimate();
}

inline void ExpectSameValues(const core::Values& a, const core::Values& b, double tol) {
  ASSERT_EQ(a.size(), b.size());
  for (core::Key k : a.keys()) {
    ASSERT_TRUE(b.Contains(k)) << core::KeyToString(k);
    EXPECT_LE(core::LocalCoordinates(a.Get(k), b.Get(k)).lpNorm<Eigen::Infinity>(), tol)
        << core::KeyToString(k);
  }
}

}  // namespace slamd::server::recovery_test
