// A replicated pair of real `slamd` processes (replication with a lease) on a real three-server
// NATS JetStream cluster, in this test's own network namespace (ctest labels ha and netns).
//
// A robot streams manhattan in lock-step (re-sending a step until its pose's estimate comes) to
// the pair's channels, and the same steps to an unreplicated slamd (the uninterrupted run). At
// seeded steps the leader is killed with SIGKILL: the standby takes the lease when it lapses,
// applies the rest of the stream and what it heard that the stream lacks, and publishes; a new
// standby is the failed process restarted on its data directory (superseded by the stream),
// starting from the newest snapshot in NATS (snapshots every 50 updates, the stream truncated
// before the older of the two kept). A supervisor restarts any process that exits deposed.
// Robots change nothing. At the end the pair's data directory and the uninterrupted one recover
// to the same estimator (every factor once, estimates within 1e-9 after convergence): nothing
// lost, nothing doubled. A leader frozen
// (SIGSTOP) instead of killed, thawed after the takeover, finds itself deposed and exits 3; so
// does a leader cut off from NATS by a network partition (each process reaches NATS through an
// address of its own on a veth device, the leader's deleted with `ip addr`, then restored),
// while the robots still reach it. A standby started on a stream truncated past what it could
// start from exits 3, and restarted with snapshots starts from the newest.
// Failover times (fault to the first estimate from the new leader) are printed; the targets are
// measured by scripts/bench-failover.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset_stream.h"
#include "server/replication/leader_lease.h"
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

// One process of `pair` (its prefix: robots see one server), its data directory and log under
// `dir`.
Server PairProcess(const Server& pair, const std::string& dir, const std::string& name) {
  Server p{.prefix = pair.prefix, .data_dir = dir + "/" + name, .log = dir + "/" + name + ".log"};
  std::filesystem::create_directories(p.data_dir);
  return p;
}

// The benchmark (scripts/bench-failover) runs the kill test with other settings:
//   SLAMD_FAILOVER_RATE   messages per second, sent without waiting (0: lock-step, the default)
//   SLAMD_FAILOVER_STEPS  steps of manhattan streamed (default 700)
//   SLAMD_FAILOVER_KILLS  leader kills, at least 2 s of stream apart at a rate (default 3)
//   SLAMD_FAILOVER_SEED   where the kills fall (default 20261205)
int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::atoi(v) : fallback;
}

constexpr const char* kConfig =
    "refine { enabled: true budget_s: 0.002 }\n"
    "isam2 { refine_threshold: 1e-10 }\n"
    "publish { status_rate_hz: 20 estimate_covariance: false }\n"
    "journal { sync: ALWAYS snapshot_every_updates: 50 }\n"
    "log_level: \"info\"\n";

// How the leader fails: killed; frozen (SIGSTOP: no lease renewals, no appends) and thawed after
// the standby took over; or partitioned from NATS (its address deleted: `ip link set down` does
// not cut an address of the same machine) and reconnected after the takeover. Frozen or
// partitioned, it must then find itself deposed and exit 3 without writing the stream.
enum class Fault { kKill, kFreeze, kPartition };

// The partition's device, and the address through which pair process i reaches NATS.
constexpr const char* kPartitionDevice = "slamd_part";
std::string PartitionAddress(int i) { return "10.77.0." + std::to_string(i + 1); }

bool Ip(const std::string& args) { return std::system(("ip " + args).c_str()) == 0; }

// Waits up to timeout_s for pid to exit; its exit code, or -1 (killed then) when it did not.
int ExitWithin(pid_t pid, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return testing::ExitCode(status);
}

// Streams every step's messages to the pair and the reference at `rate` messages per second
// without waiting (robots do not wait), kills the leader (SIGKILL) once the steps of `kill_at`
// are sent and restarts it on its data directory at once; prints each failover (kill to the
// first estimate after it).
void StreamAtRate(Client& client, Server& pair, Server& reference,
                  const std::vector<StepMessages>& messages, int rate, const std::set<int>& kill_at,
                  const std::function<int()>& leader_index, const std::function<void()>& supervise,
                  std::array<Server, 2>& procs, const std::string& config) {
  const auto period = std::chrono::nanoseconds(1000000000 / rate);
  auto next = std::chrono::steady_clock::now();
  std::int64_t failed = 0;  // a kill whose failover is not measured yet
  std::vector<double> failover_s;
  for (int k = 0; k < static_cast<int>(messages.size()); ++k) {
    for (const testing::WireMessage& m : messages[k]) {
      std::this_thread::sleep_until(next);
      next += period;
      client.Send(pair, {m});
      client.Send(reference, {m});
    }
    client.Poll();
    supervise();
    if (failed > 0 && pair.estimate_received_us > failed) {
      failover_s.push_back((pair.estimate_received_us - failed) * 1e-6);
      failed = 0;
    }
    if (kill_at.count(k)) {
      ASSERT_EQ(failed, 0) << "the previous failover is not over at step " << k;
      const int l = leader_index();
      ASSERT_GE(l, 0) << "no process holds the lease at step " << k;
      failed = testing::WallUs();
      ASSERT_NO_FATAL_FAILURE(testing::Kill(&procs[l], SIGKILL));
      client.Poll();  // what the dead leader sent: estimates from now on are the new one's
      pair.estimate_received_us = 0;
      ASSERT_NO_FATAL_FAILURE(testing::Launch(config, client, &procs[l]));
    }
  }
  if (failed > 0) {
    ASSERT_TRUE(client.PumpUntil([&] { return pair.estimate_received_us > failed; }, 30.0));
    failover_s.push_back((pair.estimate_received_us - failed) * 1e-6);
  }
  for (double f : failover_s) {
    std::printf("[ failover ] at %d msg/s: first estimate from the new leader after %.3f s\n", rate,
                f);
  }
}

void RunFailover(Fault fault, int faults, const char* tag) {
  const int rate = EnvInt("SLAMD_FAILOVER_RATE", 0);
  const int n = EnvInt("SLAMD_FAILOVER_STEPS", kSteps);
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::WireDataset data;
  testing::LoadWireDataset("manhattan.g2o", n, kRobot, &data);
  if (::testing::Test::IsSkipped()) return;
  const std::vector<core::DatasetStep>& steps = data.steps;
  const std::vector<StepMessages>& messages = data.messages;
  const int expected_factors = data.factors;

  testing::TempDir tmp(tag);
  testing::NatsCluster nats(tmp.str() + "/nats", 3);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  ASSERT_TRUE(nats.WaitForJetStream(30.0));
  // Each process's config: its own address to NATS when it is to be partitioned.
  std::array<std::string, 2> pair_configs;
  // The partition's device goes with the test (after its processes): the namespace is the next
  // test's, which expects loopback only.
  struct DeviceGone {
    ~DeviceGone() { Ip(std::string("link del ") + kPartitionDevice); }
  };
  std::optional<DeviceGone> device_gone;
  if (fault == Fault::kPartition) {
    device_gone.emplace();
    const std::string d = kPartitionDevice;
    ASSERT_TRUE(Ip("link add " + d + " type veth peer name " + d + "1") &&
                Ip("link set " + d + " up") && Ip("link set " + d + "1 up") &&
                Ip("addr add " + PartitionAddress(0) + "/32 dev " + d) &&
                Ip("addr add " + PartitionAddress(1) + "/32 dev " + d));
  }
  for (int i = 0; i < 2; ++i) {
    pair_configs[i] = tmp.str() + "/pair" + std::to_string(i) + ".textproto";
    std::ofstream(pair_configs[i])
        << kConfig << "replication { servers: \""
        << (fault == Fault::kPartition ? nats.UrlsVia(PartitionAddress(i)) : nats.Urls())
        << "\" ack_timeout_ms: 500 lease_ttl_ms: 1000 }\n";
  }
  const std::string& pair_config = pair_configs[0];
  const std::string ref_config = tmp.str() + "/reference.textproto";
  std::ofstream(ref_config) << kConfig;

  // The pair as the robot sees it (one prefix), and its processes.
  Server pair{.prefix = "F_"};
  Server reference{
      .prefix = "U_", .data_dir = tmp.str() + "/reference", .log = tmp.str() + "/reference.log"};
  auto process = [&](const std::string& name) { return PairProcess(pair, tmp.str(), name); };
  std::filesystem::create_directories(reference.data_dir);
  Client client(kUrl, kRobot);
  client.Attach(&pair);
  client.Attach(&reference);
  ASSERT_NO_FATAL_FAILURE(testing::Start(ref_config, client, &reference));
  std::array<Server, 2> procs{process("pair0"), process("pair1")};
  const testing::KillOnExit cleanup({&reference, &procs[0], &procs[1]});
  const std::int64_t t0 = testing::WallUs();
  ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_config, client, &procs[0]));
  ASSERT_TRUE(client.PumpUntil([&] { return pair.status_utime > t0; }, 30.0)) << procs[0].log;
  ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_configs[1], client, &procs[1]));
  ASSERT_TRUE(testing::WaitForLog(client, procs[1], "standby, following", 30.0)) << procs[1].log;

  // Which process leads: the lease's holder is a data directory's replication id.
  auto observer = LeaderLease::Open(
      {.nats = {.servers = nats.UrlList()}, .ttl_ms = 1000, .holder = "observer"});
  ASSERT_TRUE(observer.ok()) << observer.status().ToString();
  auto leader_index = [&] {
    const core::Result<std::string> holder = observer.value()->Holder();
    for (int i = 0; i < 2; ++i) {
      std::ifstream in(procs[i].data_dir + "/replication-id");
      std::string id;
      std::getline(in, id);
      if (holder.ok() && !id.empty() && id == holder.value()) return i;
    }
    return -1;
  };
  // A supervisor: a process that exited (deposed: 3) is restarted on its data directory, where
  // it follows as a standby (a loaded machine can make a leader miss its renewals: a failover
  // of its own). Returns how many it restarted.
  int restarts = 0;
  auto supervise = [&] {
    for (Server& p : procs) {
      int status = 0;
      if (p.pid > 0 && ::waitpid(p.pid, &status, WNOHANG) == p.pid) {
        EXPECT_EQ(testing::ExitCode(status), 3) << p.log;
        p.pid = -1;
        ++restarts;
        testing::Launch(pair_configs[&p - procs.data()], client, &p);
      }
    }
  };

  std::mt19937 rng(static_cast<unsigned>(EnvInt("SLAMD_FAILOVER_SEED", 20261205)));
  // Far enough apart for a takeover in between (2 s of stream at a rate).
  const int apart = rate > 0 ? 2 * rate * n / expected_factors : 80;
  std::set<int> fault_at;
  for (int tries = 0; static_cast<int>(fault_at.size()) < faults && tries < 100000; ++tries) {
    const int k = 100 + static_cast<int>(rng() % static_cast<unsigned>(n - 200));
    if (std::all_of(fault_at.begin(), fault_at.end(),
                    [&](int j) { return std::abs(j - k) > apart; })) {
      fault_at.insert(k);
    }
  }
  ASSERT_EQ(static_cast<int>(fault_at.size()), faults) << "too many faults for the steps";
  if (rate > 0) {
    ASSERT_EQ(fault, Fault::kKill);
    ASSERT_NO_FATAL_FAILURE(StreamAtRate(
        client, pair, reference, messages, rate, fault_at, [&] { return leader_index(); },
        supervise, procs, pair_config));
    supervise();
  }
  std::vector<double> failover_s;
  for (int k = 0; k < n && rate == 0; ++k) {
    const std::uint64_t pose = core::KeyIndex(steps[k].pose);
    ASSERT_GT(testing::SendUntilEstimated(client, &reference, messages[k], pose, 30.0, 0.5), 0)
        << k;
    supervise();
    if (fault_at.count(k)) {
      const int l = leader_index();
      ASSERT_GE(l, 0) << "no process holds the lease at step " << k;
      Server& old = procs[l];
      // The leader fails with this step sent: the standby heard it.
      client.Send(pair, messages[k]);
      const std::int64_t failed = testing::WallUs();
      const std::string address = PartitionAddress(l) + "/32 dev " + kPartitionDevice;
      if (fault == Fault::kKill) {
        ASSERT_NO_FATAL_FAILURE(testing::Kill(&old, SIGKILL));
      } else if (fault == Fault::kFreeze) {
        ASSERT_EQ(::kill(old.pid, SIGSTOP), 0);
      } else {
        ASSERT_TRUE(Ip("addr del " + address));
      }
      client.Poll();  // what the failed leader sent: estimates from now on are the new one's
      pair.estimate_received_us = 0;
      std::int64_t old_leader_until = failed;  // estimates that arrive later are the new leader's
      if (fault == Fault::kPartition) {
        // A partitioned leader still hears the clients and may still publish what NATS took
        // before the cut: only once the standby holds the lease are estimates the new leader's.
        // Ended on an estimate of the old leader's, the partition could end before the lease
        // lapsed, and the old leader, never deposed, would not exit. The new leader publishes
        // as it takes over, which can be before this sees the lease change hands: estimates
        // count from the last look that still found the old leader.
        ASSERT_TRUE(client.PumpUntil(
            [&] {
              const std::int64_t now = testing::WallUs();
              if (leader_index() == 1 - l) return true;
              old_leader_until = now;
              return false;
            },
            30.0))
            << "the standby did not take the lease after the partition at step " << k;
      }
      ASSERT_TRUE(client.PumpUntil(
          [&] { return pair.estimate_received_us > old_leader_until; }, 30.0))
          << "no estimate after the leader failed at step " << k;
      failover_s.push_back((pair.estimate_received_us - failed) * 1e-6);
      if (fault != Fault::kKill) {
        if (fault == Fault::kFreeze) {
          ASSERT_EQ(::kill(old.pid, SIGCONT), 0);
        } else {
          ASSERT_TRUE(Ip("addr add " + address));
        }
        EXPECT_EQ(ExitWithin(old.pid, 30.0), 3) << "the returning leader (" << old.log << ")";
        EXPECT_TRUE(testing::WaitForLog(client, old, "no longer the leader", 1.0)) << old.log;
        old.pid = -1;
      }
      // Restarted on its data directory, superseded by the stream: the new standby.
      ASSERT_NO_FATAL_FAILURE(testing::Launch(pair_configs[l], client, &old));
      ASSERT_TRUE(testing::WaitForLog(client, old, "moved to", 30.0)) << old.log;
      // Snapshots every 50 updates, two kept in NATS: the stream is truncated, and the new
      // standby starts from the newest snapshot there.
      EXPECT_TRUE(testing::WaitForLog(client, old, "standby starts from the snapshot", 30.0))
          << old.log;
    }
    ASSERT_GT(testing::SendUntilEstimated(client, &pair, messages[k], pose, 30.0, 0.5), 0)
        << "step " << k << " never acknowledged by the pair";
  }
  supervise();
  std::printf("[ failover ] %d restarts of deposed processes besides the faults\n", restarts);
  for (size_t i = 0; i < failover_s.size(); ++i) {
    std::printf("[ failover ] kill %zu: first estimate from the new leader after %.3f s\n", i,
                failover_s[i]);
  }
  ASSERT_TRUE(client.Barrier(&pair));
  ASSERT_TRUE(client.Barrier(&reference));
  const int l = leader_index();
  ASSERT_GE(l, 0);
  const Server& leader = procs[l];
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&procs[1 - l], SIGTERM));
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&procs[l], SIGTERM));
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&reference, SIGTERM));
  // A partitioned or thawed leader refuses what it cannot replicate until it learns it was
  // deposed (the standby heard it, and the robot re-sends); deposed, it says nothing. Nothing
  // else is refused.
  std::string reasons;
  for (const auto& [reason, count] : pair.rejects) {
    reasons += " " + std::to_string(count) + " x reason " + std::to_string(reason);
  }
  EXPECT_EQ(pair.other_rejects - pair.rejects[slamd::reject_t::REASON_REPLICATION_UNAVAILABLE], 0)
      << reasons;
  if (fault == Fault::kKill) EXPECT_EQ(pair.other_rejects, 0) << reasons;

  // The stream was truncated before the oldest snapshot kept in NATS.
  auto stream_client = NatsClient::Connect({.servers = nats.UrlList()});
  ASSERT_TRUE(stream_client.ok());
  const auto range =
      OpenStream(stream_client.value()->jetstream(), {.name = "SLAMD", .subject = "slamd.journal"});
  ASSERT_TRUE(range.ok()) << range.status().ToString();
  EXPECT_GT(range.value().first, 1);
  std::printf("[ stream ] journal stream: messages %lld-%lld kept (%lld bytes)\n",
              static_cast<long long>(range.value().first),
              static_cast<long long>(range.value().last),
              static_cast<long long>(range.value().bytes));

  const ServerParams params = testing::ConfigParams(ref_config);
  const testing::Recovered pair_state = testing::RecoverAndConverge(leader.data_dir, params);
  const testing::Recovered ref_state = testing::RecoverAndConverge(reference.data_dir, params);
  testing::ExpectSameEstimators(pair_state, ref_state, expected_factors, 1e-9);
}

TEST(FailoverHaTest, StandbyTakesOverFromAKilledLeaderAndLosesNothing) {
  RunFailover(Fault::kKill, EnvInt("SLAMD_FAILOVER_KILLS", kKills), "ha_failover_kill");
}

TEST(FailoverHaTest, AFrozenLeaderComesBackDeposedAndWritesNothing) {
  RunFailover(Fault::kFreeze, 1, "ha_failover_freeze");
}

TEST(FailoverHaTest, ALeaderPartitionedFromNatsComesBackDeposedAndLosesNothing) {
  RunFailover(Fault::kPartition, 1, "ha_failover_partition");
}

// A standby that cannot follow: started on a stream its leader has truncated, with no snapshot of
// NATS to start from (keep_snapshots: 0 on its side), it finds records missing and exits 3;
// restarted with snapshots it starts from the newest and follows.
TEST(FailoverHaTest, AStandbyMissingTruncatedRecordsExitsAndStartsAgainFromASnapshot) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::WireDataset data;
  testing::LoadWireDataset("manhattan.g2o", 300, kRobot, &data);
  if (::testing::Test::IsSkipped()) return;
  testing::TempDir tmp("ha_standby_truncated");
  testing::NatsCluster nats(tmp.str() + "/nats", 1);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  ASSERT_TRUE(nats.WaitForJetStream(30.0));
  const auto config = [&](const std::string& name, int keep) {
    const std::string file = tmp.str() + "/" + name + ".textproto";
    std::ofstream(file) << kConfig << "replication { servers: \"" << nats.Urls()
                        << "\" replicas: 1 lease_ttl_ms: 1000 keep_snapshots: " << keep << " }\n";
    return file;
  };
  Server pair{.prefix = "T_"};
  auto process = [&](const std::string& name) { return PairProcess(pair, tmp.str(), name); };
  Server leader = process("leader"), standby = process("standby");
  Client client(kUrl, kRobot);
  client.Attach(&pair);
  const testing::KillOnExit cleanup({&leader, &standby});
  const std::int64_t t0 = testing::WallUs();
  ASSERT_NO_FATAL_FAILURE(testing::Launch(config("leader", 2), client, &leader));
  ASSERT_TRUE(client.PumpUntil([&] { return pair.status_utime > t0; }, 30.0)) << leader.log;
  for (int k = 0; k < static_cast<int>(data.messages.size()); ++k) {
    ASSERT_GT(testing::SendUntilEstimated(client, &pair, data.messages[k],
                                          core::KeyIndex(data.steps[k].pose), 30.0, 0.5),
              0)
        << k;
  }
  ASSERT_TRUE(testing::WaitForLog(client, leader, "stored in the stream", 10.0)) << leader.log;
  ASSERT_NO_FATAL_FAILURE(testing::Launch(config("standby", 0), client, &standby));
  EXPECT_EQ(ExitWithin(standby.pid, 30.0), 3) << standby.log;
  standby.pid = -1;
  EXPECT_TRUE(testing::WaitForLog(client, standby, "no longer in the stream", 1.0)) << standby.log;
  ASSERT_NO_FATAL_FAILURE(testing::Launch(config("standby", 2), client, &standby));
  EXPECT_TRUE(testing::WaitForLog(client, standby, "standby starts from the snapshot", 30.0))
      << standby.log;
  EXPECT_TRUE(testing::WaitForLog(client, standby, "standby, following", 30.0)) << standby.log;
}

}  // namespace
}  // namespace slamd::server
