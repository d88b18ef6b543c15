// Durability of the daemon (server/estimator/recovery.h, server/journal): what a restart
// recovers from the data directory's journal and snapshots, driven by hand (no threads).
#include "server/estimator/recovery.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <random>

#include "server/daemon/daemon.h"
#include "server/journal/journal.h"
#include "server/journal/journal_segments.h"
#include "server/journal/read_journal.h"
#include "server/journal/snapshot_file.h"
#include "server/messages/inbound.h"
#include "server/transport/in_process_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"
#include "tests/server/daemon/recovery_test_helpers.h"
#include "tests/testing/noise.h"

namespace slamd::server {
namespace {

using namespace recovery_test;  // NOLINT: the helpers of these tests

// A restart replays the journal into exactly the same updates and refinements: the recovered
// estimate equals the one before the restart bit for bit.
TEST(RecoveryTest, RestartReproducesTheStateExactly) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(3);
  core::Values before;
  std::int64_t updates = 0;
  {
    auto d = Daemon::Create(Params(dir.str()), &bus).value();
    Stream(bus, *d, 0, 80, rng);
    before = Estimate(*d);
    updates = d->snapshot()->update_sequence;
    d->Stop();
  }
  auto d = Daemon::Create(Params(dir.str()), &bus).value();
  EXPECT_EQ(d->snapshot()->update_sequence, updates);
  ExpectSameValues(Estimate(*d), before, 0.0);
  // And it carries on: sequence numbers continue, another measurement with an old one's
  // identity is refused; the stream's exact repeats (Send) are held already, not rejected.
  std::vector<slamd::reject_t> rejects;
  Subscription sub = CollectRejects(bus, &rejects);
  const std::int64_t held = d->snapshot()->counters.already_held;
  EXPECT_GT(held, 0);
  // 79 -> 80 again, with values no stream sends (Send(79, 80) repeats the original exactly when
  // the random chunking, which depends on how fast refinement settles, started a chunk at 79).
  slamd::odometry_t other;
  ToLcm(OdometryMeasurement{79, "r", 79, 80, core::Pose2(5.0, 5.0, 1.0), Noise(3, 0.05)}, &other);
  ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", other).ok());
  Stream(bus, *d, 80, 90, rng);
  EXPECT_EQ(Estimate(*d).size(), before.size() + 10);
  ASSERT_EQ(rejects.size(), 1u);
  EXPECT_EQ(rejects[0].reason, slamd::reject_t::REASON_DUPLICATE);
  EXPECT_GT(d->snapshot()->counters.already_held, held);
}

// Swaps of a solver rebuilt in the background (EstimatorParams::background_relinearization_above)
// come whenever its thread is done, after catch-up rounds on that thread as it happens to run
// them; they are journaled with their rounds, and a restart makes the same swaps and rounds
// between the same updates: the state is again the same bit for bit.
TEST(RecoveryTest, RestartReproducesBackgroundRebuildSwapsExactly) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(5);
  ServerParams p = Params(dir.str());
  p.estimator.background_relinearization_above = 2;
  p.isam2.relinearization.skip = 1;
  p.refine.enabled = false;  // it would keep every δ under the thresholds
  core::Values before;
  std::int64_t updates = 0, rebuilds = 0;
  {
    auto d = Daemon::Create(p, &bus).value();
    Stream(bus, *d, 0, 1500, rng);
    d->Stop();
    before = Estimate(*d);
    updates = d->snapshot()->update_sequence;
    rebuilds = d->snapshot()->counters.rebuilds;
  }
  EXPECT_GT(rebuilds, 0);
  int rounds = 0;
  const core::Result<JournalContents> journal = ReadJournal(dir.str());
  ASSERT_TRUE(journal.ok()) << journal.status().ToString();
  for (const journal::JournalRecord& r : journal.value().records) {
    if (r.has_rebuild_swap()) rounds += r.rebuild_swap().catch_up_rounds_size();
  }
  EXPECT_GT(rounds, 0);  // rebuilds of hundreds of poses against updates of ~0.1 ms
  auto d = Daemon::Create(p, &bus).value();
  EXPECT_EQ(d->snapshot()->update_sequence, updates);
  EXPECT_EQ(d->snapshot()->counters.rebuilds, rebuilds);
  ExpectSameValues(Estimate(*d), before, 0.0);
}

// Messages journaled but never processed (a crash between intake and the update) are processed
// when slamd starts again, and their rejections are published then.
TEST(RecoveryTest, AcceptedButUnprocessedMessagesAreProcessedAtStart) {
  TempDir dir;
  fs::create_directories(dir.str());
  {
    auto journal =
        Journal::Open(dir.str(), {.writer = {.sync_policy = SyncPolicy::kNever}}, {}, 0).value();
    const auto append = [&](const char* channel, const auto& msg) {
      std::vector<std::uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
      msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      ASSERT_TRUE(journal->AppendMessage(channel, msg.getTypeName(), bytes, 0).ok());
    };
    slamd::prior_t prior;
    ToLcm(PriorMeasurement{1, "r", 0, PriorKind::kPose2, core::Pose2(), Noise(3, 0.01)}, &prior);
    append("SLAMD_PRIOR", prior);
    slamd::odometry_t odo;
    ToLcm(OdometryMeasurement{2, "r", 0, 1, core::Pose2(1, 0, 0), Noise(3, 0.1)}, &odo);
    append("SLAMD_ODOMETRY", odo);
    ToLcm(OdometryMeasurement{2, "r", 0, 1, core::Pose2(1, 0, 0.5), Noise(3, 0.1)}, &odo);
    append("SLAMD_ODOMETRY", odo);  // another odometry 0 -> 1: rejected when processed
  }
  InProcessBus bus;
  std::vector<slamd::reject_t> rejects;
  Subscription sub = CollectRejects(bus, &rejects);
  auto d = Daemon::Create(Params(dir.str()), &bus).value();
  ASSERT_TRUE(bus.HandleOnce(0).ok());
  EXPECT_EQ(d->snapshot()->num_variables, 2);
  ASSERT_EQ(rejects.size(), 1u);
  EXPECT_EQ(rejects[0].reason, slamd::reject_t::REASON_DUPLICATE);
  d->Stop();
  // The start journaled their update: a second restart replays it, nothing is pending.
  core::Result<RecoveryResult> again = Recover(dir.str(), {}, {}, false);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again.value().pending.empty());
  EXPECT_EQ(again.value().replayed_updates, 1);
  EXPECT_EQ(again.value().estimator->snapshot()->num_variables, 2);
}

// A crash mid-write leaves a torn record: recovery keeps every whole record before it, cuts
// the rest, and the daemon appends after the cut.
TEST(RecoveryTest, TornTailIsTruncatedAndEverythingBeforeItRecovered) {
  TempDir dir;
  RecordSession(dir, 40, 5);
  const std::string path = JournalSegmentPath(dir.str(), 0);
  const auto size = static_cast<std::int64_t>(fs::file_size(path));
  std::mt19937 cut_rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    TempDir copy;
    fs::create_directories(copy.str());
    fs::copy_file(path, JournalSegmentPath(copy.str(), 0));
    const std::int64_t cut = 16 + static_cast<std::int64_t>(cut_rng() % (size - 16));
    fs::resize_file(JournalSegmentPath(copy.str(), 0), static_cast<std::uintmax_t>(cut));
    core::Result<RecoveryResult> r = Recover(copy.str(), {}, {}, false);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    EXPECT_LE(r.value().torn_tail_offset, cut);
    // The cut file now ends on a record boundary and the daemon appends after it.
    InProcessBus bus2;
    auto d = Daemon::Create(Params(copy.str()), &bus2).value();
    const std::int64_t poses = d->snapshot()->num_variables;
    d->Stop();
    core::Result<RecoveryResult> again = Recover(copy.str(), {}, {}, false);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again.value().torn_tail_offset, -1) << "trial " << trial;
    EXPECT_EQ(again.value().estimator->snapshot()->num_variables, poses);
  }
}

// A flipped bit in the middle stops recovery with an error naming the offset; --salvage skips
// the damaged record and starts.
TEST(RecoveryTest, CorruptionInTheMiddleStopsUnlessSalvaged) {
  TempDir dir;
  RecordSession(dir, 40, 7);
  InProcessBus bus;
  // Damage an update-boundary record in the middle (a lost boundary loses no message: its
  // messages join the next update).
  const std::string path = JournalSegmentPath(dir.str(), 0);
  core::Result<JournalContents> contents = ReadJournal(path);
  ASSERT_TRUE(contents.ok());
  std::int64_t target = -1;
  for (size_t i = contents.value().records.size() / 2; i < contents.value().records.size(); ++i) {
    if (contents.value().records[i].has_boundary()) {
      target = contents.value().offsets[i] + 9;  // inside the payload
      break;
    }
  }
  ASSERT_GT(target, 0);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(target);
    char c = 0;
    f.read(&c, 1);
    c ^= 0x10;
    f.seekp(target);
    f.write(&c, 1);
  }
  core::Result<std::unique_ptr<Daemon>> refused = Daemon::Create(Params(dir.str()), &bus);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(refused.status().message().find("--salvage"), std::string::npos)
      << refused.status().ToString();
  ServerParams salvage = Params(dir.str());
  salvage.salvage = true;
  core::Result<std::unique_ptr<Daemon>> started = Daemon::Create(salvage, &bus);
  ASSERT_TRUE(started.ok()) << started.status().ToString();
  EXPECT_EQ(started.value()->snapshot()->num_variables, 41);
}

// Recovery from a snapshot plus the journal after it gives what a full replay gives (both
// settled: the snapshot re-solves at its linearisation point).
// With background rebuilds too (no refinement then: it keeps every δ under the thresholds): a
// snapshot taken while a rebuild was in flight is followed in the journal by that rebuild's swap
// record, which recovery from the snapshot skips (no rebuild in flight there).
class RecoveryRebuildTest : public ::testing::TestWithParam<bool> {};

TEST_P(RecoveryRebuildTest, SnapshotPlusJournalEqualsFullReplay) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(9);
  ServerParams p = Params(dir.str());
  p.journal.snapshot_every_updates = 15;
  p.isam2.refine_threshold = 1e-10;
  if (GetParam()) {
    p.estimator.background_relinearization_above = 2;
    p.isam2.relinearization.skip = 1;
    p.refine.enabled = false;
  }
  {
    auto d = Daemon::Create(p, &bus).value();
    Stream(bus, *d, 0, 120, rng);
    d->Stop();
  }
  core::Result<std::vector<SnapshotFileInfo>> snaps = ListSnapshots(dir.str());
  ASSERT_TRUE(snaps.ok());
  ASSERT_FALSE(snaps.value().empty());
  core::Result<RecoveryResult> with = Recover(dir.str(), p.estimator, p.isam2, false);
  ASSERT_TRUE(with.ok()) << with.status().ToString();
  EXPECT_FALSE(with.value().snapshot_path.empty())
      << (with.value().notes.empty() ? "" : with.value().notes[0]);
  EXPECT_GT(with.value().snapshot_sequence, 0);
  for (const auto& s : snaps.value()) fs::remove(s.path);
  core::Result<RecoveryResult> full = Recover(dir.str(), p.estimator, p.isam2, false);
  ASSERT_TRUE(full.ok());
  EXPECT_TRUE(full.value().snapshot_path.empty());
  EXPECT_GT(full.value().replayed_messages, with.value().replayed_messages);
  Estimator& a = *with.value().estimator;
  Estimator& b = *full.value().estimator;
  if (GetParam()) {
    EXPECT_GT(b.snapshot()->counters.rebuilds, 0);
  }
  EXPECT_EQ(a.snapshot()->num_factors, b.snapshot()->num_factors);
  for (Estimator* e : {&a, &b}) {
    for (int k = 0; k < 50 && e->Rebuilding(); ++k) {
      ASSERT_TRUE(e->FinishRebuild().ok());
    }
    ASSERT_FALSE(e->Rebuilding());
    ASSERT_TRUE(e->Refine(10.0).converged);
  }
  ExpectSameValues(a.solver().CalculateEstimate(), b.solver().CalculateEstimate(), 1e-8);
}

INSTANTIATE_TEST_SUITE_P(InlineAndBackground, RecoveryRebuildTest, ::testing::Bool());

// Snapshots take at most 5% of the time, whatever snapshot_every_updates asks: after one that
// took t (export, encoding, writing), the next waits 20 t.
TEST(RecoveryTest, SnapshotsTakeAtMostFivePercentOfTheTime) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(17);
  ServerParams p = Params(dir.str());
  p.refine.enabled = false;
  p.queue.depth = 100000;
  p.queue.max_per_update = 100000;  // the chain below in one update
  p.journal.snapshot_every_updates = 1;
  p.journal.keep_snapshots = 1000;
  auto d = Daemon::Create(p, &bus).value();
  auto count = [&] { return static_cast<int>(ListSnapshots(dir.str()).value().size()); };
  auto wait_for = [&](int n) {
    for (int i = 0; i < 30000 && count() < n; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return count() >= n;
  };
  // A plain odometry chain (Send's synthetic loop closures make GN diverge at this length).
  auto chain = [&](int from, int to) {
    if (from == 0) {
      slamd::prior_t prior;
      ToLcm(PriorMeasurement{1, "r", 0, PriorKind::kPose2, core::Pose2(), Noise(3, 0.01)}, &prior);
      ASSERT_TRUE(Publish(bus, "SLAMD_PRIOR", prior).ok());
    }
    for (int i = from; i < to; ++i) {
      slamd::odometry_t odo;
      ToLcm(OdometryMeasurement{i, "r", static_cast<std::uint64_t>(i),
                                static_cast<std::uint64_t>(i + 1), core::Pose2(1, 0, 0.01),
                                Noise(3, 0.05)},
            &odo);
      ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
    }
    Drive(*d, rng);
  };
  chain(0, 20000);  // one big update: a snapshot of 20000 poses costs tens of ms
  const auto update_end = std::chrono::steady_clock::now();
  ASSERT_TRUE(wait_for(1));
  const auto write_time = std::chrono::steady_clock::now() - update_end;  // <= its cost t
  const auto start = std::chrono::steady_clock::now();
  for (int k = 20000; k < 20020; ++k) chain(k, k + 1);
  const auto updates_time = std::chrono::steady_clock::now() - start;
  // The gate counts from the snapshot's start (export included); a wide margin for that and the
  // polling.
  ASSERT_LT(updates_time, 10 * write_time) << "too slow to tell";
  EXPECT_EQ(count(), 1) << "a snapshot right after the last one";
  std::this_thread::sleep_for(25 * write_time + std::chrono::milliseconds(100));
  chain(20020, 20021);
  EXPECT_TRUE(wait_for(2)) << "no snapshot once 5% of the time allows one";
  d->Stop();
}

// Disk full (a file-size limit): intake rejects with REASON_STORAGE_ERROR and keeps running;
// nothing rejected is in the graph; when writing works again, intake resumes.
TEST(RecoveryTest, DiskFullRejectsThenResumes) {
  std::signal(SIGXFSZ, SIG_IGN);
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(13);
  auto d = Daemon::Create(Params(dir.str()), &bus).value();
  std::vector<slamd::reject_t> rejects;
  Subscription sub = CollectRejects(bus, &rejects);
  Send(bus, 0, 10);
  Drive(*d, rng);
  const std::int64_t poses = d->snapshot()->num_variables;
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  rlimit small = old;
  small.rlim_cur = fs::file_size(JournalSegmentPath(dir.str(), 0));
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  const size_t before = rejects.size();
  Send(bus, 10, 15);
  Drive(*d, rng);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  EXPECT_EQ(d->snapshot()->num_variables, poses);  // nothing from the full disk got in
  ASSERT_GT(rejects.size(), before);
  for (size_t i = before; i < rejects.size(); ++i) {
    EXPECT_EQ(rejects[i].reason, slamd::reject_t::REASON_STORAGE_ERROR);
    EXPECT_NE(rejects[i].detail.find("journal"), std::string::npos) << rejects[i].detail;
  }
  Send(bus, 9, 20);  // 9->10 is a duplicate; 10..19 are new again
  Drive(*d, rng);
  EXPECT_EQ(d->snapshot()->num_variables, poses + 10);
  d->Stop();
  core::Result<RecoveryResult> r = Recover(dir.str(), {}, {}, false);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r.value().estimator->snapshot()->num_variables, poses + 10);
}

}  // namespace
}  // namespace slamd::server
