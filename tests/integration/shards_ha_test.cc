// Map shards through real processes: a NATS server and, inside this test's own network
// namespace (scripts/netns-run; ctest labels ha and netns), a 4-robot world streamed over UDP LCM
// to one unsharded slamd and to 2 and to 4 shards (robots split in order) that exchange
// summaries over NATS; the robots close loops with each other and see landmarks of the shared
// map between their lines. Every robot's poses from its shard end within 1 mm of the unsharded
// slamd's, and the shards sent summaries. Shards on two buses (two channel prefixes) with
// shards.forward_queries answer a query, a map request and a bad query for the other shard's
// robot on the asker's bus, exactly as the owner answers on its own. A shard that is a replicated
// pair loses its leader half-way and still ends at the unsharded estimate.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "server/messages/inbound.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/map_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/reject_t.hpp"
#include "tests/testing/nats_cluster.h"
#include "tests/testing/noise.h"
#include "tests/testing/processes.h"
#include "tests/testing/slamd_processes.h"

namespace slamd::server {
namespace {

using core::Pose2;
using testing::Client;
using testing::Server;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152";
// The messages go out in bursts of 40 with this pause [ms] after each, in which every process
// (each takes both servers' messages off the multicast group) is to read them; at 5 ms a shard
// lost 2 of ~450 once while the whole suite ran on two cores, and this test has no re-send.
constexpr int kBurstPauseMs = 20;
constexpr int kRobots = 4;
constexpr int kPoses = 40;

// kRobots robots on parallel lines 3 m apart (a prior each on its true start, noisy odometry),
// closures between every pair of robots at a few poses, and landmarks of the shared map midway
// between neighbouring lines every 4 m, each seen (bearing and range) by the robots on both
// sides: (suffix, bytes) in sending order.
std::vector<std::pair<std::string, std::vector<std::uint8_t>>> World() {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n(0.0, 0.03);
  const auto noisy = [&](const Pose2& z) {
    return z.Retract(core::Vector3(n(rng), n(rng), n(rng)));
  };
  const auto truth = [](int r, int i) { return Pose2(1.0 * i, 3.0 * r, 0.0); };
  const auto name = [](int r) { return "robot" + std::to_string(r); };
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> out;
  const auto add = [&](const char* suffix, const auto& msg) {
    std::vector<std::uint8_t> bytes;
    EXPECT_TRUE(Encode(msg, &bytes).ok());
    out.emplace_back(suffix, std::move(bytes));
  };
  for (int r = 0; r < kRobots; ++r) {
    slamd::prior_t prior;
    ToLcm(PriorMeasurement{1, name(r), 0, PriorKind::kPose2, truth(r, 0),
                           ::slamd::testing::Noise(3, 0.01)},
          &prior);
    add("PRIOR", prior);
  }
  for (int i = 0; i + 1 < kPoses; ++i) {
    for (int r = 0; r < kRobots; ++r) {
      slamd::odometry_t odo;
      ToLcm(OdometryMeasurement{2, name(r), std::uint64_t(i), std::uint64_t(i + 1),
                                noisy(truth(r, i).Between(truth(r, i + 1))),
                                ::slamd::testing::Noise(3, 0.05)},
            &odo);
      add("ODOMETRY", odo);
      for (int side : {-1, 1}) {  // the landmarks between this line and its neighbours'
        const int gap = side < 0 ? r - 1 : r;  // between lines gap and gap + 1
        if (gap < 0 || gap + 1 >= kRobots) continue;
        for (int k = 0; 4 * k < kPoses; ++k) {
          const double dx = 4.0 * k + 0.5 - (i + 1), dy = 3.0 * gap + 1.5 - 3.0 * r;
          if (std::abs(dx) > 1.6) continue;
          slamd::landmark_observation_t obs;
          ToLcm(LandmarkMeasurement{4, name(r), std::uint64_t(i + 1), std::uint64_t(100 * gap + k),
                                    LandmarkKind::kBearingRange2,
                                    BearingRange{std::atan2(dy, dx) + 0.01 * n(rng),
                                                 std::hypot(dx, dy) + 0.3 * n(rng)},
                                    ::slamd::testing::Noise(2, 0.02), LandmarkNamespace::kMap},
                &obs);
          add("LANDMARK", obs);
        }
      }
    }
    if (i % 9 != 8) continue;
    for (int a = 0; a < kRobots; ++a) {
      for (int b = 0; b < kRobots; ++b) {
        if (a == b || (a + b + i / 9) % 2 == 0) continue;
        const int j = a < b ? i - 1 : i;
        slamd::loop_closure_t loop;
        ToLcm(LoopClosureMeasurement{3,
                                     name(a),
                                     std::uint64_t(i + 1),
                                     name(b),
                                     std::uint64_t(j),
                                     noisy(truth(a, i + 1).Between(truth(b, j))),
                                     ::slamd::testing::Noise(3, 0.05),
                                     {}},
              &loop);
        add("LOOP_CLOSURE", loop);
      }
    }
  }
  return out;
}

constexpr const char* kConfig =
    "refine { enabled: true idle_s: 0 }\n"
    "isam2 { wildfire_threshold: 0 refine_threshold: 1e-9 }\n"
    "publish { status_rate_hz: 10 estimate_covariance: false }\n"
    "journal { sync: NEVER }\n"
    "log_level: \"info\"\n";

// The config of shard `self` of `n` (robots split in order) exchanging over `nats`.
std::string ShardConfig(int n, int self, const std::string& nats, bool forward_queries = false) {
  std::string c = std::string(kConfig) + "shards {\n  self: \"S" + std::to_string(self) + "\"\n";
  for (int s = 0; s < n; ++s) {
    c += "  shard { name: \"S" + std::to_string(s) + "\"";
    for (int r = s * kRobots / n; r < (s + 1) * kRobots / n; ++r) {
      c += " robots: \"robot" + std::to_string(r) + "\"";
    }
    c += " }\n";
  }
  return c + "  servers: \"" + nats + "\"\n  summary_every_ms: 100\n" +
         (forward_queries ? "  forward_queries: true\n" : "") + "}\n";
}

// What the slamd(s) on one prefix answered to one query.
struct Answer {
  bool replied = false;              // by every shard answering (query_reply_t.shards_answering)
  slamd::query_reply_t reply;        // the last reply
  std::set<std::string> shards;      // the shards that replied
  int announced_pages = 0;           // the replies' map_pages
  int map_pages = 0;                 // map_t pages of the request
  std::set<std::string> map_robots;  // their robots
  int rejects = 0;                   // reject_t of the query's client
};

// Asks the slamd(s) on `prefix` (the robot's shard answers).
class Asker {
 public:
  Asker() : bus_(LcmBus::Create(LcmBusParams{.url = kUrl}).value()) {}
  Answer Ask(const std::string& prefix, QueryRequest q) {
    q.client = "shards_test";
    q.request_id = ++id_;
    slamd::query_t msg;
    ToLcm(q, &msg);
    Answer a;
    auto replies = Subscribe<slamd::query_reply_t>(
        *bus_, prefix + "QUERY_REPLY",
        [&](std::string_view, const slamd::query_reply_t& r) {
          if (r.request_id != id_ || !a.shards.insert(r.shard).second) return;
          a.reply = r;
          a.announced_pages += r.map_pages;
          a.replied = static_cast<int>(a.shards.size()) >= r.shards_answering;
        },
        nullptr);
    auto pages = Subscribe<slamd::map_t>(
        *bus_, prefix + "MAP",
        [&](std::string_view, const slamd::map_t& m) {
          if (m.request_id != id_) return;
          ++a.map_pages;
          a.map_robots.insert(m.robot);
        },
        nullptr);
    auto rejects = Subscribe<slamd::reject_t>(
        *bus_, prefix + "REJECT",
        [&](std::string_view, const slamd::reject_t& r) { a.rejects += r.robot == q.client; },
        nullptr);
    EXPECT_TRUE(Publish(*bus_, prefix + "QUERY", msg).ok());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!a.replied && std::chrono::steady_clock::now() < deadline) (void)bus_->HandleOnce(20);
    (void)bus_->HandleOnce(50);  // a reject_t after its reply
    return a;
  }
  // Every pose of `robot` (poses not found far away; none when there was no reply).
  std::vector<Pose2> Poses(const std::string& prefix, const std::string& robot) {
    QueryRequest q;
    for (int i = 0; i < kPoses; ++i) q.keys.push_back({robot, KeyKind::kPose, std::uint64_t(i)});
    std::vector<Pose2> poses;
    for (const slamd::variable_t& v : Ask(prefix, q).reply.results) {
      poses.push_back(v.found ? Pose2(v.values[0], v.values[1], v.values[2]) : Pose2(1e9, 1e9, 0));
    }
    return poses;
  }

 private:
  std::unique_ptr<LcmBus> bus_;
  std::int64_t id_ = 0;
};

// The largest distance between a robot's poses from the shards and from the central slamd.
double Gap(Asker& asker) {
  double gap = 0.0;
  for (int r = 0; r < kRobots; ++r) {
    const std::string robot = "robot" + std::to_string(r);
    const std::vector<Pose2> shard = asker.Poses("SLAMD_", robot);
    const std::vector<Pose2> central = asker.Poses("CENTRAL_", robot);
    if (shard.size() != kPoses || central.size() != kPoses) return 1e9;
    for (int i = 0; i < kPoses; ++i) {
      gap = std::max(gap, (shard[i].translation() - central[i].translation()).norm());
    }
  }
  return gap;
}

// Gap() once the shards have settled (within 1 mm), or after 60 s.
double SettledGap(Client& client) {
  Asker asker;
  double gap = 1e9;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (gap > 1e-3 && std::chrono::steady_clock::now() < deadline) {
    client.Drain(300);
    gap = Gap(asker);
  }
  return gap;
}

void RunShards(int n) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::TempDir tmp("ha_shards_" + std::to_string(n));
  testing::NatsCluster nats(tmp.str() + "/nats", 1);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  Client client(kUrl, "robot0");
  Server central{
      .prefix = "CENTRAL_", .data_dir = tmp.str() + "/central", .log = tmp.str() + "/central.log"};
  std::vector<Server> shards(n);
  std::vector<Server*> all = {&central};
  for (int s = 0; s < n; ++s) {
    shards[s] = Server{.prefix = "SLAMD_",
                       .data_dir = tmp.str() + "/s" + std::to_string(s),
                       .log = tmp.str() + "/s" + std::to_string(s) + ".log"};
    all.push_back(&shards[s]);
  }
  const testing::KillOnExit cleanup(all);
  std::ofstream(tmp.str() + "/central.textproto") << kConfig;
  ASSERT_NO_FATAL_FAILURE(testing::Launch(tmp.str() + "/central.textproto", client, &central));
  for (int s = 0; s < n; ++s) {
    const std::string config = tmp.str() + "/s" + std::to_string(s) + ".textproto";
    std::ofstream(config) << ShardConfig(n, s, nats.Urls());
    ASSERT_NO_FATAL_FAILURE(testing::Launch(config, client, &shards[s]));
  }
  client.Attach(&shards[0]);  // the shards' status_t (any of them)
  for (Server* s : all)
    ASSERT_TRUE(testing::WaitForLog(client, *s, "slamd running", 30.0)) << s->log;

  testing::StepMessages step;
  for (auto& [suffix, bytes] : World()) step.push_back({suffix, std::move(bytes), nullptr});
  for (std::size_t k = 0; k < step.size(); k += 40) {  // in bursts a socket buffer takes
    const testing::StepMessages burst(step.begin() + k,
                                      step.begin() + std::min(step.size(), k + 40));
    client.Send(central, burst);
    client.Send(shards[0], burst);
    client.Drain(kBurstPauseMs);
  }
  const double gap = SettledGap(client);
  EXPECT_LT(gap, 1e-3) << "shard logs in " << tmp.str();
  client.Drain(300);
  EXPECT_GT(shards[0].status.shard_summaries_sent, 0);
  EXPECT_GT(shards[0].status.shard_not_owned, 0);
  EXPECT_EQ(shards[0].other_rejects, 0);
}

TEST(ShardsHaTest, TwoShardsOverNatsEndAtOneServersEstimate) { RunShards(2); }
TEST(ShardsHaTest, FourShardsOverNatsEndAtOneServersEstimate) { RunShards(4); }

// Shard S1 of two is a replicated pair on a three-server JetStream cluster. Its leader is killed
// (SIGKILL) half-way through the stream; the standby, which kept S0's summaries and the robots'
// messages it heard, takes over, sends S1's summaries, and the shards end at the one server's
// estimate as before.
TEST(ShardsHaTest, AShardThatIsAReplicatedPairFailsOverAndEndsAtOneServersEstimate) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::TempDir tmp("ha_shards_pair");
  testing::NatsCluster nats(tmp.str() + "/nats", 3);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  ASSERT_TRUE(nats.WaitForJetStream(30.0));
  Client client(kUrl, "robot0");
  const auto server = [&](const std::string& prefix, const std::string& name) {
    return Server{.prefix = prefix,
                  .data_dir = tmp.str() + "/" + name,
                  .log = tmp.str() + "/" + name + ".log"};
  };
  Server central = server("CENTRAL_", "central");
  std::vector<Server> procs;  // S0, then S1's leader and standby (not copyable: no push_back)
  procs.reserve(3);
  for (const char* name : {"s0", "s1a", "s1b"}) procs.push_back(server("SLAMD_", name));
  const testing::KillOnExit cleanup({&central, &procs[0], &procs[1], &procs[2]});
  std::ofstream(tmp.str() + "/central.textproto") << kConfig;
  std::ofstream(tmp.str() + "/s0.textproto") << ShardConfig(2, 0, nats.Urls());
  std::ofstream(tmp.str() + "/s1.textproto")
      << ShardConfig(2, 1, nats.Urls()) << "replication { servers: \"" << nats.Urls()
      << "\" ack_timeout_ms: 500 lease_ttl_ms: 1000 }\n";
  ASSERT_NO_FATAL_FAILURE(testing::Launch(tmp.str() + "/central.textproto", client, &central));
  ASSERT_NO_FATAL_FAILURE(testing::Launch(tmp.str() + "/s0.textproto", client, &procs[0]));
  ASSERT_NO_FATAL_FAILURE(testing::Launch(tmp.str() + "/s1.textproto", client, &procs[1]));
  client.Attach(&procs[0]);
  for (Server* s : {&central, &procs[0], &procs[1]}) {
    ASSERT_TRUE(testing::WaitForLog(client, *s, "slamd running", 30.0)) << s->log;
  }
  ASSERT_NO_FATAL_FAILURE(testing::Launch(tmp.str() + "/s1.textproto", client, &procs[2]));
  ASSERT_TRUE(testing::WaitForLog(client, procs[2], "standby, following", 30.0)) << procs[2].log;

  testing::StepMessages step;
  for (auto& [suffix, bytes] : World()) step.push_back({suffix, std::move(bytes), nullptr});
  for (std::size_t k = 0; k < step.size(); k += 40) {
    if (k == step.size() / 80 * 40) {  // half-way: S1's leader dies
      client.Drain(200);               // S0's summaries of the first half are out
      ASSERT_NO_FATAL_FAILURE(testing::Kill(&procs[1], SIGKILL));
    }
    const testing::StepMessages burst(step.begin() + k,
                                      step.begin() + std::min(step.size(), k + 40));
    client.Send(central, burst);
    client.Send(procs[0], burst);
    client.Drain(kBurstPauseMs);
  }
  ASSERT_TRUE(testing::WaitForLog(client, procs[2], "took over as leader", 30.0)) << procs[2].log;
  const double gap = SettledGap(client);
  EXPECT_LT(gap, 1e-3) << "logs in " << tmp.str();
  EXPECT_EQ(procs[0].other_rejects, 0);
  // The new leader sent S1's summaries (it says how many when it stops).
  ASSERT_NO_FATAL_FAILURE(testing::Kill(&procs[2], SIGTERM));
  std::ifstream in(procs[2].log);
  const std::string log{std::istreambuf_iterator<char>(in), {}};
  const std::size_t at = log.rfind("shard 'S1': ");  // the stop line
  ASSERT_NE(at, std::string::npos) << procs[2].log;
  EXPECT_GT(std::atoi(log.c_str() + at + 12), 0) << log.substr(at, 80);
}

// Two shards, each on its own bus (prefixes A_ and B_: neither hears the other's channels), both
// sent the whole world (each takes its robots'). Asked on A_, S0 forwards robot2's and robot3's
// queries, a fleet-wide map and a query of keys of both shards to S1 and publishes S1's answers
// on A_.
TEST(ShardsHaTest, QueriesForAnotherShardsRobotAreForwardedBetweenBuses) {
  ASSERT_TRUE(testing::OnlyLoopback()) << testing::kNotInNetns;
  if (!testing::HaveNatsServer()) GTEST_SKIP() << "nats-server is not installed";
  testing::TempDir tmp("ha_shards_forward");
  testing::NatsCluster nats(tmp.str() + "/nats", 1);
  ASSERT_NO_FATAL_FAILURE(nats.StartAll());
  Client client(kUrl, "robot0");
  std::vector<Server> shards(2);  // not copyable
  shards[0] = Server{.prefix = "A_", .data_dir = tmp.str() + "/s0", .log = tmp.str() + "/s0.log"};
  shards[1] = Server{.prefix = "B_", .data_dir = tmp.str() + "/s1", .log = tmp.str() + "/s1.log"};
  const testing::KillOnExit cleanup({&shards[0], &shards[1]});
  for (int s = 0; s < 2; ++s) {
    const std::string config = tmp.str() + "/s" + std::to_string(s) + ".textproto";
    std::ofstream(config) << ShardConfig(2, s, nats.Urls(), /*forward_queries=*/true);
    ASSERT_NO_FATAL_FAILURE(testing::Launch(config, client, &shards[s]));
  }
  client.Attach(&shards[0]);
  for (Server& s : shards) {
    ASSERT_TRUE(testing::WaitForLog(client, s, "queries forwarded", 30.0)) << s.log;
  }
  testing::StepMessages step;
  for (auto& [suffix, bytes] : World()) step.push_back({suffix, std::move(bytes), nullptr});
  for (std::size_t k = 0; k < step.size(); k += 40) {
    const testing::StepMessages burst(step.begin() + k,
                                      step.begin() + std::min(step.size(), k + 40));
    client.Send(shards[0], burst);
    client.Send(shards[1], burst);
    client.Drain(kBurstPauseMs);
  }
  // Settled: the owner's answer on its own bus and the forwarded one agree.
  Asker asker;
  const auto gap = [&](const std::string& robot) {
    const std::vector<Pose2> direct = asker.Poses("B_", robot);
    const std::vector<Pose2> forwarded = asker.Poses("A_", robot);
    if (direct.size() != kPoses || forwarded.size() != kPoses) return 1e9;
    double g = 0.0;
    for (int i = 0; i < kPoses; ++i) {
      g = std::max(g, (direct[i].translation() - forwarded[i].translation()).norm());
      if (direct[i].translation().norm() > 1e3) return 1e9;  // not found
    }
    return g;
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  double worst = 1e9;
  while (worst > 1e-9 && std::chrono::steady_clock::now() < deadline) {
    client.Drain(300);
    worst = std::max(gap("robot2"), gap("robot3"));
  }
  EXPECT_LT(worst, 1e-9) << "logs in " << tmp.str();

  // A map request for robot3, asked on A_: its pages come on A_MAP.
  const Answer map = asker.Ask("A_", QueryRequest{.map_robot = "robot3"});
  ASSERT_TRUE(map.replied);
  EXPECT_EQ(map.reply.status, slamd::query_reply_t::STATUS_OK) << map.reply.error;
  EXPECT_GT(map.map_pages, 0);
  EXPECT_EQ(map.reply.map_pages, map.map_pages);
  // A bad query for robot2 (a joint marginal of more keys than allowed): S1's rejection, on A_.
  QueryRequest bad{.want_joint_marginal = true};
  for (int i = 0; i < 20; ++i) bad.keys.push_back({"robot2", KeyKind::kPose, std::uint64_t(i)});
  const Answer rejected = asker.Ask("A_", bad);
  ASSERT_TRUE(rejected.replied);
  EXPECT_EQ(rejected.reply.status, slamd::query_reply_t::STATUS_REJECTED);
  EXPECT_NE(rejected.reply.error.find("joint marginal"), std::string::npos) << rejected.reply.error;
  EXPECT_EQ(rejected.rejects, 1);
  // A fleet-wide map asked on A_: every shard answers with its own robots, all on A_.
  const Answer fleet = asker.Ask("A_", QueryRequest{.map_robot = "*"});
  ASSERT_TRUE(fleet.replied);
  EXPECT_EQ(fleet.shards, (std::set<std::string>{"S0", "S1"}));
  EXPECT_EQ(fleet.map_pages, fleet.announced_pages);
  for (int r = 0; r < kRobots; ++r) {
    EXPECT_EQ(fleet.map_robots.count("robot" + std::to_string(r)), 1u) << r;
  }
  // Keys of both shards' robots asked on A_: each owner answers (S1's reply forwarded).
  const Answer both = asker.Ask(
      "A_", QueryRequest{.keys = {{"robot0", KeyKind::kPose, 1}, {"robot2", KeyKind::kPose, 1}}});
  ASSERT_TRUE(both.replied);
  EXPECT_EQ(both.shards, (std::set<std::string>{"S0", "S1"}));
  // S0's own robot is answered by S0 (not forwarded).
  EXPECT_EQ(asker.Poses("A_", "robot0").size(), kPoses);
  client.Drain(300);
  EXPECT_GE(shards[0].status.shard_queries_forwarded, 2 + 2 + 1 + 1);
  EXPECT_GT(shards[0].status.shard_not_owned, 0);  // S1's robots' measurements
}

}  // namespace
}  // namespace slamd::server
