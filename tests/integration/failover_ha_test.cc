// A replicated pair of real `slamd` processes (replication with a lease) on a real three-server
// NATS JetStream cluster, in this test's own network namespace (ctest labels ha and netns).
//
// A robot streams manhattan in lock-step (re-sending a step until its pose's estimate comes) to
// the pair's channels, and the same steps to an unreplicated slamd (the uninterrupted run). At
// seeded steps the leader is killed with SIGKILL: the standby takes the lease when it lapses,
// applies the rest of the stream and what it heard that the stream lacks, and publishes; a new
// standby is started on an empty data directory. Robots change nothing. At the end the pair's
// data directory and the uninterrupted one recover to the same estimator (every factor once,
// estimates within 1e-9 after convergence): nothing lost, nothing doubled. Failover times (kill
// to the first estimate from the new leader) are printed; the targets are measured by
// scripts/bench-failover.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/io/dataset_stream.h"
#include "tests/testing/datasets.h"
#include "tests/testing/estimator_compare.h"
#include "tests/testing/nats_cluster.h"
#include "tests/testing/processes.h"
#include "tests/testing/slamd_processes.h"
#include "tests/testing/wire_steps.h"

namespace slamd::server {
namespace {

using testing::Client;
using testing::Server;
using testing::StepMessages;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152";
constexpr const char* kRobot = "manhattan";
constexpr int kSteps = 700;
constexpr int kKills = 3;

constexpr const char* kConfig =
    "refine { enabled: true budget_s: 0.002 }\n"
    "isam2 { refine_threshold: 1e-10 }\n"
    "publish { status_rate_hz: 20 estimate_covariance: false }\n"
    "journal { sync: ALWAYS }\n"
    "log_level: \"info\"\n";

TEST(FailoverHaTest, StandbyTakesOverFromAKilledLeaderAndLosesNothing) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  const std::string path = testing::SharedDatasetPath("manhattan.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const std::vector<core::DatasetStep> steps =
      core::MakeIncrementalSteps(core::ReadDataset(path).value());
  int expected_factors = 0;
  const std::vector<StepMessages> messages =
      testing::MakeWireSteps(steps, kSteps, kRobot, 1e-3, &expected_factors);

  testing::TempDir tmp("ha_failover");
  testing::NatsCluster nats(tmp.str() + "/nats", 3);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  ASSERT_TRUE(nats.WaitForJetStream(30.0));
  const std::string pair_config = tmp.str() + "/pair.textproto";
  std::ofstream(pair_config) << kConfig << "replication { servers: \"" << nats.Urls()
                             << "\" ack_timeout_ms: 500 lease_ttl_ms: 1000 }\n";
  const std::string ref_config = tmp.str() + "/reference.textproto";
  std::ofstream(ref_config) << kConfig;

  // The pair as the robot sees it (one prefix), and its processes.
  Server pair{.prefix = "F_"};
  Server reference{
      .prefix = "U_", .data_dir = tmp.str() + "/reference", .log = tmp.str() + "/reference.log"};
  int generation = 0;
  auto process = [&] {
    const std::string name = "pair" + std::to_string(generation++);
    Server p{.prefix = pair.prefix,
             .data_dir = tmp.str() + "/" + name,
             .log = tmp.str() + "/" + name + ".log"};
    std::filesystem::create_directories(p.data_dir);
    return p;
  };
  std::filesystem::create_directories(reference.data_dir);
  Client client(kUrl, kRobot);
  client.Attach(&pair);
  client.Attach(&reference);
  ASSERT_NO_FATAL_FAILURE(testing::Start(ref_config, client, &reference));
  Server leader = process(), standby = process();
  const std::int64_t t0 = testing::WallUs();
  ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_config, client, &leader));
  ASSERT_TRUE(client.PumpUntil([&] { return pair.status_utime > t0; }, 30.0)) << leader.log;
  ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_config, client, &standby));
  ASSERT_TRUE(testing::WaitForLog(client, standby, "standby, following", 30.0)) << standby.log;

  std::mt19937 rng(20261205);
  std::set<int> kill_at;
  while (static_cast<int>(kill_at.size()) < kKills) {
    const int k = 100 + static_cast<int>(rng() % static_cast<unsigned>(kSteps - 200));
    if (std::all_of(kill_at.begin(), kill_at.end(), [&](int j) { return std::abs(j - k) > 80; })) {
      kill_at.insert(k);
    }
  }
  std::vector<double> failover_s;
  for (int k = 0; k < kSteps; ++k) {
    const std::uint64_t pose = core::KeyIndex(steps[k].pose);
    ASSERT_GT(testing::SendUntilEstimated(client, &reference, messages[k], pose, 30.0, 0.5), 0)
        << k;
    if (kill_at.count(k)) {
      // The leader dies with this step sent: the standby heard it.
      client.Send(pair, messages[k]);
      const std::int64_t killed = testing::WallUs();
      ASSERT_NO_FATAL_FAILURE(testing::Kill(&leader, SIGKILL));
      ASSERT_TRUE(client.PumpUntil([&] { return pair.estimate_received_us > killed; }, 30.0))
          << "no estimate after the leader was killed at step " << k << " (" << standby.log << ")";
      failover_s.push_back((pair.estimate_received_us - killed) * 1e-6);
      leader = std::move(standby);
      standby = process();
      ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_config, client, &standby));
      ASSERT_TRUE(testing::WaitForLog(client, standby, "standby, following", 30.0)) << standby.log;
    }
    ASSERT_GT(testing::SendUntilEstimated(client, &pair, messages[k], pose, 30.0, 0.5), 0)
        << "step " << k << " never acknowledged by the pair (" << leader.log << ")";
  }
  for (size_t i = 0; i < failover_s.size(); ++i) {
    std::printf("[ failover ] kill %zu: first estimate from the new leader after %.3f s\n", i,
                failover_s[i]);
  }
  ASSERT_TRUE(client.Barrier(&pair));
  ASSERT_TRUE(client.Barrier(&reference));
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&standby, SIGTERM));
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&leader, SIGTERM));
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&reference, SIGTERM));
  EXPECT_EQ(pair.other_rejects, 0);

  const ServerParams params = testing::ConfigParams(ref_config);
  const testing::Recovered pair_state = testing::RecoverAndConverge(leader.data_dir, params);
  const testing::Recovered ref_state = testing::RecoverAndConverge(reference.data_dir, params);
  testing::ExpectSameEstimators(pair_state, ref_state, expected_factors, 1e-9);
}

}  // namespace
}  // namespace slamd::server
