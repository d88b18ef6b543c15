// The daemon's publishing: query replies, maps, status, removals, estimates before the rest of
// the map is solved and only once their messages are durable.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

#include "server/daemon/daemon.h"
#include "server/journal/read_journal.h"
#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/map_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/status_t.hpp"
#include "slamd_proto/journal.pb.h"
#include "tests/server/daemon/daemon_test_client.h"

namespace slamd::server {
namespace {

using namespace daemon_test;  // NOLINT: the shared messages and client

slamd::query_t Query(std::int64_t id, std::vector<std::uint64_t> poses, bool marginals, bool joint,
                     const std::string& map_robot = "") {
  QueryRequest q{.utime = 1, .client = "tester", .request_id = id};
  for (std::uint64_t i : poses) q.keys.push_back({"r", KeyKind::kPose, i});
  q.want_marginals = marginals;
  q.want_joint_marginal = joint;
  q.map_robot = map_robot;
  slamd::query_t msg;
  ToLcm(q, &msg);
  return msg;
}

// Queries are answered after the update of the messages queued before them; estimates carry
// the newest pose's covariance; maps come in pages. Reference: a prior (sigma a) and identity
// odometry (sigma b) give x1 the covariance (a² + b²) I and x0, x1 the cross-covariance a² I.
TEST(DaemonTest, QueriesEstimateCovariancesAndMapsAnswered) {
  InProcessBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  Client client(bus);
  std::vector<slamd::query_reply_t> replies;
  std::vector<slamd::map_t> maps;
  client.subs.push_back(
      Subscribe<slamd::query_reply_t>(
          bus, "SLAMD_QUERY_REPLY",
          [&](std::string_view, const slamd::query_reply_t& m) { replies.push_back(m); }, nullptr)
          .value());
  client.subs.push_back(Subscribe<slamd::map_t>(
                            bus, "SLAMD_MAP",
                            [&](std::string_view, const slamd::map_t& m) { maps.push_back(m); },
                            nullptr)
                            .value());
  const double a = 0.01, b = 0.1;
  slamd::odometry_t odo;
  ToLcm(OdometryMeasurement{10, "r", 0, 1, core::Pose2(), Noise(3, b)}, &odo);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
  ASSERT_TRUE(Publish(bus, "SLAMD_QUERY", Query(7, {0, 1, 5}, true, false)).ok());
  ASSERT_TRUE(Publish(bus, "SLAMD_QUERY", Query(8, {0, 1}, true, true, "*")).ok());
  slamd::query_t bad = Query(9, {0}, false, false);
  bad.client = "bad name!";
  ASSERT_TRUE(Publish(bus, "SLAMD_QUERY", bad).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  EXPECT_EQ(daemon->StepEstimator(0.0), 4);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());

  ASSERT_EQ(client.estimates.size(), 1u);
  ASSERT_EQ(client.estimates[0].num_covariance, 9);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(client.estimates[0].covariance[3 * i + j], i == j ? a * a + b * b : 0.0, 1e-12);
    }
  }
  ASSERT_EQ(replies.size(), 3u);
  // The invalid query is rejected at intake, so its reply comes first (and a reject_t).
  EXPECT_EQ(replies[0].request_id, 9);
  EXPECT_EQ(replies[0].status, slamd::query_reply_t::STATUS_REJECTED);
  EXPECT_NE(replies[0].error.find("client"), std::string::npos) << replies[0].error;
  ASSERT_EQ(client.rejects.size(), 1u);
  EXPECT_EQ(client.rejects[0].message_type, "query_t");

  const slamd::query_reply_t& r7 = replies[1];
  EXPECT_EQ(r7.request_id, 7);
  EXPECT_EQ(r7.client, "tester");
  EXPECT_EQ(r7.update_sequence, 1);
  EXPECT_EQ(r7.status, slamd::query_reply_t::STATUS_OK);
  ASSERT_EQ(r7.num_results, 3);
  EXPECT_TRUE(r7.results[0].found);
  EXPECT_TRUE(r7.results[1].found);
  EXPECT_FALSE(r7.results[2].found);  // pose 5 does not exist
  EXPECT_EQ(r7.results[2].key.index, 5);
  ASSERT_EQ(r7.results[0].num_covariance, 9);
  EXPECT_NEAR(r7.results[0].covariance[0], a * a, 1e-12);
  EXPECT_NEAR(r7.results[1].covariance[8], a * a + b * b, 1e-12);
  EXPECT_EQ(r7.joint_dimension, 0);
  EXPECT_EQ(r7.map_pages, 0);

  const slamd::query_reply_t& r8 = replies[2];
  EXPECT_EQ(r8.status, slamd::query_reply_t::STATUS_OK) << r8.error;
  ASSERT_EQ(r8.joint_dimension, 6);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) {
      double expected = 0.0;
      if (i % 3 == j % 3) expected = (i >= 3 && j >= 3) ? a * a + b * b : a * a;
      EXPECT_NEAR(r8.joint_covariance[6 * i + j], expected, 1e-12) << i << "," << j;
    }
  }
  EXPECT_EQ(r8.map_pages, 1);
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_EQ(maps[0].robot, "r");
  EXPECT_EQ(maps[0].request_id, 8);
  EXPECT_EQ(maps[0].page_count, 1);
  ASSERT_EQ(maps[0].num_poses, 2);
  EXPECT_EQ(maps[0].poses[1].index, 1);
  ASSERT_EQ(maps[0].poses[1].num_covariance, 9);
  EXPECT_NEAR(maps[0].poses[1].covariance[4], a * a + b * b, 1e-12);
  EXPECT_EQ(maps[0].num_landmarks, 0);
}

TEST(DaemonTest, RemovedLoopClosureLeavesTheGraph) {
  InProcessBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  const auto before = daemon->snapshot();
  slamd::loop_closure_t wrong;
  ToLcm(LoopClosureMeasurement{11, "r", 4, "r", 0, core::Pose2(3, 2, 1), Noise(3, 0.1), {}},
        &wrong);
  ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", wrong).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  EXPECT_EQ(daemon->snapshot()->num_factors, before->num_factors + 1);
  EXPECT_GT(daemon->snapshot()->chi2, 1.0);
  slamd::remove_factor_t remove;
  ToLcm(RemoveFactorRequest{12, RemoveTarget::kLoopClosure, "r", 4, "r", 0, 0}, &remove);
  ASSERT_TRUE(Publish(bus, "SLAMD_REMOVE_FACTOR", remove).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  EXPECT_TRUE(client.rejects.empty());
  const auto after = daemon->snapshot();
  EXPECT_EQ(after->num_factors, before->num_factors);
  EXPECT_EQ(after->residual_dimension, before->residual_dimension);
  EXPECT_LT(after->chi2, 1e-6);
}

// Clients wait for "settled": a status_t goes out as soon as the estimate settles, whatever
// the configured rate.
TEST(DaemonTest, StatusPublishedAtOnceWhenSettled) {
  InProcessBus bus;
  ServerParams p = Params();
  p.refine.enabled = true;
  p.refine.idle_s = 0.0;
  p.publish.status_rate_hz = 0.001;  // one per 1000 s otherwise
  auto daemon = Daemon::Create(p, &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  for (int k = 0; k < 100 && (k == 0 || !daemon->snapshot()->settled); ++k) {
    daemon->StepEstimator(0.0);
  }
  ASSERT_TRUE(daemon->snapshot()->settled);
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  ASSERT_GE(client.statuses.size(), 2u);  // the first one, and the one when it settled
  EXPECT_FALSE(client.statuses.front().settled);
  EXPECT_TRUE(client.statuses.back().settled);
}

// Without a journal nothing would keep held messages across a restart: Stop answers them.
TEST(DaemonTest, StopWithoutJournalRejectsHeldMessages) {
  InProcessBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  Client client(bus);
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(3, 4)).ok());  // pose 3 never comes
  ASSERT_TRUE(daemon->PumpIntake(0).ok());
  daemon->StepEstimator(0.0);
  daemon->Stop();
  ASSERT_TRUE(bus.HandleOnce(0).ok());
  ASSERT_EQ(client.rejects.size(), 1u);
  EXPECT_EQ(client.rejects[0].reason, slamd::reject_t::REASON_OUT_OF_ORDER_TIMEOUT);
  EXPECT_EQ(client.rejects[0].channel, "SLAMD_ODOMETRY");
  EXPECT_NE(client.rejects[0].detail.find("stopped"), std::string::npos);
}

// An InProcessBus that notes, as each estimate_t is published, its pose, how far the daemon's
// journal is durable at that moment, and whether the solver still had part of its
// back-substitution to do.
class DurabilityProbeBus final : public Bus {
 public:
  core::Status Publish(std::string_view channel, std::span<const std::uint8_t> bytes) override {
    const Daemon* d = daemon.load();
    if (channel == "SLAMD_ESTIMATE" && d != nullptr) {
      slamd::estimate_t m;
      EXPECT_GT(m.decode(bytes.data(), 0, static_cast<int>(bytes.size())), 0);
      std::lock_guard lock(mutex);
      const Journal* journal = d->journal_for_tests();
      published.push_back({m.pose_index, journal ? journal->durable_offset() : -1});
      solve_pending.push_back(d->estimator_for_tests().solver().back_substitution_pending());
    }
    return inner.Publish(channel, bytes);
  }
  core::Result<Subscription> Subscribe(std::string_view channel_regex,
                                       MessageCallback callback) override {
    return inner.Subscribe(channel_regex, std::move(callback));
  }
  core::Result<int> HandleFor(std::chrono::microseconds timeout) override {
    return inner.HandleFor(timeout);
  }

  InProcessBus inner;
  std::atomic<const Daemon*> daemon{nullptr};
  std::mutex mutex;
  std::vector<std::pair<std::int64_t, std::int64_t>> published;  // (pose, durable offset)
  std::vector<bool> solve_pending;
};

// Each update's estimate goes out once the newest pose is solved, before the rest of the map's
// back-substitution (Estimator::Process with finish_later), which is done when the step ends.
TEST(DaemonTest, EstimatesGoOutBeforeTheRestOfTheMapIsSolved) {
  DurabilityProbeBus bus;
  auto daemon = Daemon::Create(Params(), &bus).value();
  bus.daemon = daemon.get();
  ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
  for (int i = 0; i < 60; ++i) {
    ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
    if (i % 10 == 9) {
      slamd::loop_closure_t loop;
      ToLcm(LoopClosureMeasurement{20,
                                   "r",
                                   static_cast<std::uint64_t>(i + 1),
                                   "r",
                                   static_cast<std::uint64_t>(i - 8),
                                   core::Pose2(0.5, 0.2, 0.1),
                                   Noise(3, 0.2),
                                   {}},
            &loop);
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", loop).ok());
    }
    ASSERT_TRUE(daemon->PumpIntake(0).ok());
    ASSERT_GT(daemon->StepEstimator(0.0), 0);
    EXPECT_FALSE(daemon->estimator_for_tests().solver().back_substitution_pending());
  }
  bus.daemon = nullptr;
  std::lock_guard lock(bus.mutex);
  ASSERT_EQ(bus.published.size(), 60u);
  EXPECT_EQ(bus.published.back().first, 60);
  for (size_t k = 0; k < bus.solve_pending.size(); ++k) EXPECT_TRUE(bus.solve_pending[k]) << k;
}

// journal.sync = ALWAYS, the daemon's own threads: no estimate goes out before the messages it
// reflects are durable (the estimator commits after each update, then publishes).
TEST(DaemonTest, AlwaysJournalPublishesAnEstimateOnlyOnceItsMessagesAreDurable) {
  const std::string dir = FreshDataDir("durable");
  ServerParams p = Params();
  p.data_dir = dir;
  p.journal.sync = SyncPolicy::kAlways;
  constexpr int kPoses = 300;
  DurabilityProbeBus bus;
  {
    auto daemon = Daemon::Create(p, &bus).value();
    bus.daemon = daemon.get();
    daemon->Start();
    ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", Prior()).ok());
    for (int i = 0; i < kPoses; ++i) {
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", Odo(i, i + 1)).ok());
      if (i % 10 == 0) std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard lock(bus.mutex);
        if (!bus.published.empty() && bus.published.back().first == kPoses) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    daemon->Stop();
    bus.daemon = nullptr;
  }
  // Message sequence 1 is the prior, 1 + k the odometry to pose k (one intake thread, FIFO bus).
  const JournalContents journal = ReadJournal(dir).value();
  std::vector<std::int64_t> message_end(kPoses + 2, -1);
  for (size_t i = 0; i < journal.records.size(); ++i) {
    if (!journal.records[i].has_message()) continue;
    const std::int64_t end =
        i + 1 < journal.records.size() ? journal.offsets[i + 1] : journal.valid_end_offset;
    message_end.at(static_cast<size_t>(journal.records[i].message().sequence())) = end;
  }
  std::lock_guard lock(bus.mutex);
  ASSERT_FALSE(bus.published.empty());
  EXPECT_EQ(bus.published.back().first, kPoses);
  for (const auto& [pose, durable] : bus.published) {
    ASSERT_GT(message_end.at(static_cast<size_t>(pose) + 1), 0) << "pose " << pose;
    EXPECT_GE(durable, message_end.at(static_cast<size_t>(pose) + 1)) << "pose " << pose;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace slamd::server
