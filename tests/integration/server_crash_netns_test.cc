// Crash test of the real `slamd`, over udpm:// ttl=0 inside a private network namespace
// (scripts/netns-run; ctest label netns, skipped with 77 where none can be made).
//
// Two servers run side by side on different channel prefixes, each on its own data directory:
// A runs uninterrupted, B is killed with SIGKILL at 12 random steps (fixed seed) and restarted on
// the same directory. The client streams manhattan in lock-step
// (waits for each pose's estimate_t) to both; half of the kills land while a step is being sent
// to B, the others after a random delay. After a kill it reads B's journal to learn which of
// the messages not yet acknowledged (the current step and the one before: lock-step waits only
// for a pose's estimate, which can come before that step's loop closures are journaled) were
// journaled, restarts B and re-sends both steps whole: exactly the journaled ones must be held
// already (status_t.messages_already_held; nothing doubled, nothing rejected), the others are
// applied (nothing lost). Then everything is re-sent to B once more: all of it held already. At
// the end both settle (refine on, refine_threshold 1e-10), are stopped with SIGTERM, and both
// data directories are recovered in-process (server/estimator/recovery.h): after refinement to
// convergence the estimates agree to 1e-9 and the factor sets are identical.
// A second test kills slamd during a burst, cuts the journal inside its last record (what a
// crash inside write() leaves) and checks that the restart truncates the torn tail and that
// re-sending the burst restores every measurement exactly once.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/io/dataset_stream.h"
#include "server/config/config_loader.h"
#include "server/estimator/recovery.h"
#include "server/journal/journal.h"
#include "server/journal/read_journal.h"
#include "server/messages/inbound.h"
#include "server/snapshot/estimator_state.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/datasets.h"
#include "tests/testing/estimator_compare.h"
#include "tests/testing/processes.h"
#include "tests/testing/slamd_processes.h"
#include "tests/testing/wire_steps.h"

namespace slamd::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::Client;
using testing::ConfigParams;
using testing::ExpectSameEstimators;
using testing::Factors;
using testing::Kill;
using testing::OnlyLoopback;
using testing::RecoverAndConverge;
using testing::Recovered;
using testing::Server;
using testing::Start;
using testing::StepMessages;
using testing::TempDir;
using testing::WallUs;
using testing::WireMessage;

// A larger receive buffer: re-sent bursts come back as bursts of reject_t.
constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152";
constexpr const char* kRobot = "manhattan";
constexpr double kAnchorSigma = 1e-3;
// Steps of manhattan streamed by the crash test (all of them: 3500 poses, 5453 edges).
constexpr int kCrashSteps = 3500;
constexpr int kKills = 12;

// Refinement on with a tiny threshold, so "settled" means converged; snapshots every 300 updates
// so restarts recover from snapshot + journal tail as well as from the journal alone; journal
// segments of 64 KiB, so kills land around segment changes and deletions of covered segments.
constexpr const char* kConfig =
    "refine { enabled: true budget_s: 0.002 }\n"
    "isam2 { refine_threshold: 1e-10 }\n"
    "publish { status_rate_hz: 20 estimate_covariance: false }\n"
    "journal { sync: ALWAYS snapshot_every_updates: 300 snapshot_every_s: 0 segment_bytes: 65536 "
    "}\n"
    "log_level: \"info\"\n";

// How many of `step`'s messages are in the journal of `dir` (same channel, same bytes).
int Journaled(const std::string& dir, const std::string& prefix, const StepMessages& step) {
  core::Result<JournalContents> c = ReadJournal(dir);
  SLAMD_CHECK(c.ok()) << c.status().ToString();
  int n = 0;
  for (const WireMessage& m : step) {
    const std::string bytes(m.bytes.begin(), m.bytes.end());
    for (const journal::JournalRecord& r : c.value().records) {
      if (r.has_message() && r.message().channel() == prefix + m.suffix &&
          r.message().lcm_payload() == bytes) {
        ++n;
        break;
      }
    }
  }
  return n;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(ServerCrashNetnsTest, KilledServerRecoversToTheUninterruptedResult) {
  ASSERT_TRUE(OnlyLoopback()) << testing::kNotInNetns;
  const std::string path = testing::SharedDatasetPath("manhattan.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const std::vector<core::DatasetStep> steps =
      core::MakeIncrementalSteps(core::ReadDataset(path).value());
  const int n = std::min<int>(kCrashSteps, static_cast<int>(steps.size()));
  int expected_factors = 0;
  const std::vector<StepMessages> messages =
      testing::MakeWireSteps(steps, n, kRobot, kAnchorSigma, &expected_factors);

  TempDir tmp("crash_main");
  const std::string config = tmp.str() + "/slamd.textproto";
  std::ofstream(config) << kConfig;
  Server a{.prefix = "A_", .data_dir = tmp.str() + "/a", .log = tmp.str() + "/a.log"};
  Server b{.prefix = "B_", .data_dir = tmp.str() + "/b", .log = tmp.str() + "/b.log"};
  fs::create_directories(a.data_dir);
  fs::create_directories(b.data_dir);
  Client client(kUrl, kRobot);
  client.Attach(&a);
  client.Attach(&b);
  ASSERT_NO_FATAL_FAILURE(Start(config, client, &a));
  ASSERT_NO_FATAL_FAILURE(Start(config, client, &b));

  // Kill points: kKills distinct steps, and a delay after sending each (so the kill lands in
  // intake, in the journal append, in the update or while publishing).
  std::mt19937 rng(20261122);
  std::set<int> kill_at;
  while (static_cast<int>(kill_at.size()) < kKills) {
    kill_at.insert(5 + static_cast<int>(rng() % static_cast<unsigned>(n - 10)));
  }
  std::uniform_int_distribution<int> delay_us(0, 800);

  int kills = 0, resent_held = 0, resent_applied = 0;
  const auto t0 = Clock::now();
  for (int k = 0; k < n; ++k) {
    const std::uint64_t pose = core::KeyIndex(steps[k].pose);
    ASSERT_NO_FATAL_FAILURE(client.Send(a, messages[k]));
    if (kill_at.count(k)) {
      // Half of the kills land while the step is being sent (after `sent` of its messages, at
      // once), the others after all of it, following a random delay.
      const int size = static_cast<int>(messages[k].size());
      const int sent =
          kills % 2 == 0 ? static_cast<int>(rng() % static_cast<unsigned>(size)) : size;
      ASSERT_NO_FATAL_FAILURE(
          client.Send(b, StepMessages(messages[k].begin(), messages[k].begin() + sent)));
      if (sent == size) std::this_thread::sleep_for(std::chrono::microseconds(delay_us(rng)));
      ASSERT_NO_FATAL_FAILURE(Kill(&b, SIGKILL));
      ++kills;
      client.Drain(20);
      // Unacknowledged: step k, and step k-1 as well, since the estimate of pose k-1 that
      // released it can come before its loop closures are journaled (they follow its odometry).
      // Steps before k-1 are journaled: the odometry into pose k-1 came after them.
      const int journaled_prev = Journaled(b.data_dir, b.prefix, messages[k - 1]);
      const int journaled = Journaled(b.data_dir, b.prefix, messages[k]);
      ASSERT_NO_FATAL_FAILURE(Start(config, client, &b));
      // Resume: steps k-1 and k again, whole. Exactly the journaled ones must be held already
      // (nothing doubled, nothing rejected), the others are applied (nothing lost).
      const std::int64_t held_before = b.status.messages_already_held;
      ASSERT_NO_FATAL_FAILURE(client.Send(b, messages[k - 1]));
      ASSERT_NO_FATAL_FAILURE(client.Send(b, messages[k]));
      ASSERT_TRUE(client.Barrier(&b)) << "no query reply from the restarted slamd at step " << k;
      const std::int64_t t1 = WallUs();
      ASSERT_TRUE(client.PumpUntil([&] { return b.status_utime > t1; }, 20.0));
      EXPECT_EQ(b.status.messages_already_held - held_before, journaled_prev + journaled)
          << "steps " << k - 1 << " and " << k << " re-sent after the kill at step " << k
          << ": the journaled messages must be held already, the others applied";
      EXPECT_TRUE(b.dups.empty()) << "a re-sent message was rejected as a duplicate";
      const int resent = static_cast<int>(messages[k - 1].size() + messages[k].size());
      resent_held += journaled_prev + journaled;
      resent_applied += resent - journaled_prev - journaled;
    } else {
      ASSERT_NO_FATAL_FAILURE(client.Send(b, messages[k]));
      ASSERT_TRUE(client.PumpUntil([&] { return b.estimated.count(pose) > 0; }, 20.0))
          << "no estimate of pose " << pose << " from B at step " << k;
    }
    ASSERT_TRUE(client.PumpUntil([&] { return a.estimated.count(pose) > 0; }, 20.0))
        << "no estimate of pose " << pose << " from A at step " << k;
  }
  const double stream_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::printf(
      "[ crash    ] %d steps (%d factors) streamed in %.1f s with %d kills; re-sent "
      "after kills: %d held already, %d applied\n",
      n, expected_factors, stream_s, kills, resent_held, resent_applied);
  EXPECT_EQ(kills, kKills);
  EXPECT_EQ(a.other_rejects, 0);
  EXPECT_EQ(b.other_rejects, 0);
  EXPECT_TRUE(a.dups.empty()) << "the uninterrupted run rejected a duplicate";

  // A robot that lost track re-sends everything: every message is held already by B, nothing
  // is rejected or added.
  {
    const std::int64_t held_before = b.status.messages_already_held;
    int total = 0;
    for (int k = 0; k < n; ++k) {
      ASSERT_NO_FATAL_FAILURE(client.Send(b, messages[k]));
      total += static_cast<int>(messages[k].size());
      if (k % 50 == 49) {
        ASSERT_TRUE(client.Barrier(&b));  // paced: no receive-buffer overrun
      }
    }
    ASSERT_TRUE(client.Barrier(&b));
    const std::int64_t t1 = WallUs();
    ASSERT_TRUE(client.PumpUntil([&] { return b.status_utime > t1; }, 20.0));
    EXPECT_EQ(b.status.messages_already_held - held_before, total);
    EXPECT_EQ(b.status.num_factors, expected_factors);
    EXPECT_TRUE(b.dups.empty());
    EXPECT_EQ(b.other_rejects, 0);
  }

  // Let both settle (refinement converged), then stop them cleanly.
  auto settled = [&](const Server& s) {
    return s.status.settled && s.status.num_factors == expected_factors &&
           s.status.queue_depth == 0;
  };
  const bool both = client.PumpUntil([&] { return settled(a) && settled(b); }, 20.0);
  std::printf("[ crash    ] servers settled: %s (A chi2 %.6f, B chi2 %.6f)\n",
              both ? "yes" : "no (refined in-process below)", a.status.chi2, b.status.chi2);
  ASSERT_NO_FATAL_FAILURE(Kill(&a, SIGTERM));
  ASSERT_NO_FATAL_FAILURE(Kill(&b, SIGTERM));
  const std::string blog = ReadText(b.log);
  EXPECT_NE(blog.find("recovered"), std::string::npos) << blog.substr(0, 2000);

  for (const Server* s : {&a, &b}) {
    const JournalContents j = ReadJournal(s->data_dir).value();
    std::printf("[ crash    ] %s journal: offsets %lld..%lld, %zu segment(s), %lld bytes on disk\n",
                s->prefix.c_str(), static_cast<long long>(j.segments.front().base),
                static_cast<long long>(j.file_size), j.segments.size(),
                static_cast<long long>(j.disk_bytes));
  }
  // Snapshots covered the start of the uninterrupted run's journal: those segments are gone.
  EXPECT_GT(ReadJournal(a.data_dir).value().segments.front().base, 0);
  const ServerParams params = ConfigParams(config);
  const auto r0 = Clock::now();
  const Recovered ra = RecoverAndConverge(a.data_dir, params);
  const Recovered rb = RecoverAndConverge(b.data_dir, params);
  std::printf("[ crash    ] recovered and converged both in %.2f s\n",
              std::chrono::duration<double>(Clock::now() - r0).count());
  ExpectSameEstimators(ra, rb, expected_factors, 1e-9);
}

// kill -9 during a burst, then the journal cut inside its last record (a torn write): the
// restart truncates the tail, and re-sending the burst restores each measurement exactly once.
TEST(ServerCrashNetnsTest, TornJournalTailAfterKillDuringBurst) {
  ASSERT_TRUE(OnlyLoopback()) << testing::kNotInNetns;
  const std::string path = testing::SharedDatasetPath("manhattan.g2o");
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const std::vector<core::DatasetStep> steps =
      core::MakeIncrementalSteps(core::ReadDataset(path).value());
  constexpr int kBurst = 400;
  int expected_factors = 0;
  const std::vector<StepMessages> messages =
      testing::MakeWireSteps(steps, kBurst, kRobot, kAnchorSigma, &expected_factors);

  TempDir tmp("crash_torn");
  const std::string config = tmp.str() + "/slamd.textproto";
  // One segment: the cut must land in the newest (a tear in an older one is corruption, and a
  // burst journaled past 64 KiB starts a second).
  std::string one_segment = kConfig;
  const size_t at = one_segment.find("segment_bytes: 65536");
  ASSERT_NE(at, std::string::npos);
  one_segment.replace(at, std::strlen("segment_bytes: 65536"), "segment_bytes: 67108864");
  std::ofstream(config) << one_segment;
  Server c{.prefix = "C_", .data_dir = tmp.str() + "/c", .log = tmp.str() + "/c.log"};
  fs::create_directories(c.data_dir);
  Client client(kUrl, kRobot);
  client.Attach(&c);
  ASSERT_NO_FATAL_FAILURE(Start(config, client, &c));
  for (int k = 0; k < kBurst; ++k) ASSERT_NO_FATAL_FAILURE(client.Send(c, messages[k]));
  // Kill as soon as slamd has journaled something (a loaded machine may take a while to start).
  const std::string journal_path = JournalSegmentPath(c.data_dir, 0);
  const auto has_message = [&] {
    const core::Result<JournalContents> r = ReadJournal(journal_path);
    if (!r.ok()) return false;
    for (const auto& record : r.value().records) {
      if (record.has_message()) return true;
    }
    return false;
  };
  for (int waited_ms = 0; waited_ms < 5000 && !has_message(); ++waited_ms) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_NO_FATAL_FAILURE(Kill(&c, SIGKILL));

  // Cut the journal inside its last message record.
  core::Result<JournalContents> before = ReadJournal(journal_path);
  ASSERT_TRUE(before.ok()) << before.status().ToString();
  const JournalContents& j = before.value();
  int last = -1;
  for (int i = 0; i < static_cast<int>(j.records.size()); ++i) {
    if (j.records[i].has_message()) last = i;
  }
  ASSERT_GE(last, 0) << "nothing was journaled before the kill";
  const std::int64_t record_end =
      last + 1 < static_cast<int>(j.offsets.size()) ? j.offsets[last + 1] : j.valid_end_offset;
  const std::int64_t cut = j.offsets[last] + (record_end - j.offsets[last]) / 2;
  std::printf("[ torn     ] %zu records journaled before the kill; cutting at byte %lld of %lld\n",
              j.records.size(), static_cast<long long>(cut), static_cast<long long>(j.file_size));
  fs::resize_file(journal_path, static_cast<std::uintmax_t>(cut));
  ASSERT_EQ(ReadJournal(journal_path).value().end, JournalReadState::kTornTail);

  ASSERT_NO_FATAL_FAILURE(Start(config, client, &c));
  for (int k = 0; k < kBurst; ++k) {
    ASSERT_NO_FATAL_FAILURE(client.Send(c, messages[k]));
    if (k % 50 == 49) {
      ASSERT_TRUE(client.Barrier(&c));  // paced: no receive-buffer overrun
    }
  }
  ASSERT_TRUE(client.Barrier(&c));
  ASSERT_NO_FATAL_FAILURE(Kill(&c, SIGTERM));
  const std::string log = ReadText(c.log);
  EXPECT_NE(log.find("torn journal tail"), std::string::npos) << log.substr(0, 2000);
  // (Other rejects are possible here: a burst message lost with the process can leave later
  // ones waiting for a pose until they time out; they are applied when re-sent.)
  std::printf(
      "[ torn     ] re-sent burst: %d duplicates, %d other rejects\n",
      [&] {
        int n = 0;
        for (const auto& [u, d] : c.dups) n += d;
        return n;
      }(),
      c.other_rejects);

  // Every measurement exactly once: the recovered graph has the burst's factors, none doubled.
  const ServerParams params = ConfigParams(config);
  const Recovered r = RecoverAndConverge(c.data_dir, params);
  const core::Values e = r.estimator->solver().CalculateEstimate();
  std::set<std::string> unique;
  for (const auto& [id, v] : Factors(r.state.factors, e)) unique.insert(id);
  EXPECT_EQ(static_cast<int>(r.state.factors.size()), expected_factors);
  EXPECT_EQ(static_cast<int>(unique.size()), expected_factors) << "a factor is doubled";
  EXPECT_EQ(static_cast<int>(e.size()), kBurst);
}

}  // namespace
}  // namespace slamd::server
