// Durability of the lifelong settings (journal segments deleted under snapshots, the pose window,
// the reduced pose graph): what a restart recovers, driven by hand (no threads).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "server/estimator/recovery.h"
#include "server/journal/journal_segments.h"
#include "server/journal/read_journal.h"
#include "server/journal/snapshot_file.h"
#include "tests/server/daemon/recovery_test_helpers.h"

namespace slamd::server {
namespace {

using namespace recovery_test;  // NOLINT: the helpers of these tests

// With one snapshot kept, the disk holds the journal segment its position falls in and those
// after it, none before. (How many snapshots a run writes depends on the machine's speed.) A
// snapshot that ends exactly where its segment does may find that segment still the one being
// written, which is never deleted: it goes with the next snapshot, so the second segment may
// begin at the snapshot's position.
void ExpectOnlySegmentsFromTheSnapshotOn(const std::string& dir) {
  const std::vector<SnapshotFileInfo> snapshots = ListSnapshots(dir).value();
  ASSERT_EQ(snapshots.size(), 1u);
  const std::int64_t position = snapshots[0].sequence;  // a snapshot is named by its position
  const std::vector<JournalSegment> segments = ListJournalSegments(dir).value();
  ASSERT_FALSE(segments.empty());
  EXPECT_LE(segments.front().base, position);
  if (segments.size() > 1) EXPECT_GE(segments[1].base, position);
}

// Journal segments a kept snapshot covers are deleted as snapshots are written, so the disk holds
// the journal since the oldest kept snapshot; recovery from what is left settles where the live
// daemon settled, before and after a restart that carries on deleting. With the lifelong window
// on too, snapshots carry its containers. Without the snapshots the deleted segments are
// missed: DataLoss, not a silent partial state.
TEST(RecoveryTest, CoveredJournalSegmentsAreDeletedAndRecoveryStaysExact) {
  TempDir dir;
  ServerParams p = Params(dir.str());
  p.journal.segment_bytes = 4096;
  p.journal.snapshot_every_updates = 10;
  p.journal.keep_snapshots = 1;  // the 5% rule leaves few snapshots in a run this short
  p.isam2.refine_threshold = 1e-10;
  p.isam2.wildfire_threshold = 0.0;  // settled means at the optimum, not within the wildfire
  p.estimator.window = {.keep_poses = 40, .keyframe_spacing_m = 2.0, .every_updates = 10};
  const auto first_base = [&] { return ListJournalSegments(dir.str()).value().front().base; };
  // Streams poses from `from` on, settles, stops; returns the settled estimate and the pose it
  // ended at. After two thirds of the way to `to` it goes on in steps of 10 poses with pauses
  // between them, past `to` if need be, until the journal's first segment is beyond `base`: the
  // 5% rule allows the next snapshot once 20x the last one's time has passed, however slow the
  // machine is.
  const auto session = [&](int from, int to, std::int64_t base, unsigned seed) {
    InProcessBus bus;
    std::mt19937 rng(seed);
    auto d = Daemon::Create(p, &bus).value();
    int k = (from + 2 * to) / 3;
    Stream(bus, *d, from, k, rng);
    for (; k < to || (first_base() <= base && k < to + 300); k += 10) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      Stream(bus, *d, k, k + 10, rng);
    }
    for (int i = 0; i < 1000 && !d->snapshot()->settled; ++i) d->StepEstimator(0.0);
    EXPECT_TRUE(d->snapshot()->settled);
    d->Stop();
    return std::make_pair(Estimate(*d), k);
  };
  const auto recovered = [&] {
    core::Result<RecoveryResult> r = Recover(dir.str(), p.estimator, p.isam2, false);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    EXPECT_FALSE(r.value().snapshot_path.empty());
    Estimator& e = *r.value().estimator;
    EXPECT_GT(e.snapshot()->counters.removed_variables, 0);
    EXPECT_TRUE(e.Refine(10.0).converged);
    return e.solver().CalculateEstimate();
  };

  const auto [first, end] = session(0, 150, 0, 21);
  ExpectSameValues(recovered(), first, 1e-8);
  const std::int64_t deleted_up_to = first_base();
  EXPECT_GT(deleted_up_to, 0);
  ExpectOnlySegmentsFromTheSnapshotOn(dir.str());

  // A restart carries on: new snapshots delete further segments.
  const core::Values settled = session(end, end + 100, deleted_up_to, 22).first;
  EXPECT_GT(first_base(), deleted_up_to);
  ExpectOnlySegmentsFromTheSnapshotOn(dir.str());
  ExpectSameValues(recovered(), settled, 1e-8);

  const std::vector<SnapshotFileInfo> snapshots = ListSnapshots(dir.str()).value();
  for (const SnapshotFileInfo& s : snapshots) fs::remove(s.path);
  core::Result<RecoveryResult> lost = Recover(dir.str(), p.estimator, p.isam2, false);
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.status().code(), core::StatusCode::kDataLoss);
  EXPECT_NE(lost.status().message().find("older segments were deleted"), std::string::npos)
      << lost.status().message();
}

// The lifelong window removes each robot's old poses but keyframes as it goes, so the graph
// stays bounded; the removals are journaled, and a restart replays them into exactly the same
// state. The removed poses up to 200 behind the window are journaled as aliases and recovered:
// a loop closure to one is applied, to an older removed pose rejected, not a failure.
TEST(RecoveryTest, PoseWindowKeepsTheGraphBoundedAndReplaysExactly) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(31);
  ServerParams p = Params(dir.str());
  p.estimator.window = {
      .keep_poses = 30, .keyframe_spacing_m = 2.0, .every_updates = 10, .keep_aliases = 200};
  core::Values before;
  std::int64_t removed = 0;
  {
    auto d = Daemon::Create(p, &bus).value();
    Stream(bus, *d, 0, 400, rng);
    before = Estimate(*d);
    removed = d->snapshot()->counters.removed_variables;
    d->Stop();
  }
  EXPECT_GT(removed, 200);
  EXPECT_EQ(static_cast<std::int64_t>(before.size()), 401 - removed);
  // What is left behind the window: keyframes, one per place (the trajectory circles a ring of
  // ~21 m again and again: ~10 places of 2 m), oldest first. (The last window ran up to 10
  // updates of 1-6 poses before the end: poses within 90 of the newest may not have been seen.)
  std::vector<core::Key> old;
  for (core::Key k : before.keys()) {
    if (core::KeyIndex(k) + 90 < 400) old.push_back(k);
  }
  std::sort(old.begin(), old.end());  // one robot: by index
  ASSERT_GE(old.size(), 5u);
  EXPECT_LE(old.size(), 20u);
  EXPECT_EQ(core::KeyIndex(old.front()), 0u);
  for (size_t i = 0; i < old.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      const core::Point2 a = before.At<core::Pose2>(old[j]).translation();
      const core::Point2 b = before.At<core::Pose2>(old[i]).translation();
      EXPECT_GE((b - a).norm(), 2.0 - 0.5) << core::KeyToString(old[i]);  // estimates move on
    }
  }
  int records = 0, aliases = 0;
  const JournalContents journal = ReadJournal(dir.str()).value();
  for (const journal::JournalRecord& r : journal.records) {
    if (!r.has_removal()) continue;
    ++records;
    const auto& keys = r.removal().keys();
    for (const snapshot::PoseAlias& a : r.removal().aliases()) {
      ++aliases;
      EXPECT_NE(std::find(keys.begin(), keys.end(), a.pose()), keys.end()) << a.pose();
      EXPECT_EQ(std::find(keys.begin(), keys.end(), a.anchor()), keys.end()) << a.anchor();
    }
    // The values the removal marginalised at: the removed poses' and their blanket's.
    std::set<std::uint64_t> at;
    for (const auto& v : r.removal().at()) at.insert(v.key());
    for (std::uint64_t k : r.removal().keys()) EXPECT_EQ(at.count(k), 1u) << k;
    EXPECT_GT(at.size(), static_cast<size_t>(r.removal().keys_size()));
  }
  EXPECT_GT(records, 0) << journal.records.size() << " records";
  EXPECT_GT(aliases, 100);

  auto d = Daemon::Create(p, &bus).value();
  ExpectSameValues(Estimate(*d), before, 0.0);
  EXPECT_EQ(d->snapshot()->counters.removed_variables, removed);
  std::vector<slamd::reject_t> rejects;
  Subscription sub = CollectRejects(bus, &rejects);
  // Pose 300 was removed (a non-keyframe, 100 behind the window), pose 1 too long ago.
  const std::uint8_t robot = core::KeyRobot(old.front());
  std::uint64_t held = 300;
  while (before.Contains(core::MakeKey('x', held, robot))) ++held;
  ASSERT_LT(held, 360u);
  const std::int64_t applied = d->snapshot()->counters.applied;
  slamd::loop_closure_t lc;
  ToLcm(LoopClosureMeasurement{9, "r", 400, "r", held, core::Pose2(), Noise(3, 0.1), {}}, &lc);
  ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
  Drive(*d, rng);
  EXPECT_TRUE(rejects.empty()) << rejects[0].detail;
  EXPECT_EQ(d->snapshot()->counters.applied, applied + 1);
  ToLcm(LoopClosureMeasurement{10, "r", 400, "r", 1, core::Pose2(), Noise(3, 0.1), {}}, &lc);
  ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
  Drive(*d, rng);
  ASSERT_EQ(rejects.size(), 1u);
  EXPECT_EQ(rejects[0].reason, slamd::reject_t::REASON_UNKNOWN_POSE) << rejects[0].detail;
}

// A robot circling a ring of 21 poses for 400 poses, with loop closures a lap back that agree
// with its true path (Send's synthetic closures disagree with its odometry by a radian: the
// reduced graph composes them onto few nodes, where refinement then does not settle).
void SendRing(Bus& bus, int from, int to) {
  std::mt19937 rng(from);
  std::normal_distribution<double> n(0.0, 0.02);
  const core::Pose2 step(1.0, 0.0, 2 * M_PI / 21);
  const auto truth = [&](int i) {
    core::Pose2 p;
    for (int k = 0; k < i % 21; ++k) p = p * step;
    return p;
  };
  if (from == 0) SendAnchor(bus);
  for (int i = from; i < to; ++i) {
    slamd::odometry_t odo;
    ToLcm(OdometryMeasurement{i, "r", static_cast<std::uint64_t>(i),
                              static_cast<std::uint64_t>(i + 1),
                              step * core::Pose2(n(rng), n(rng), n(rng)), Noise(3, 0.02)},
          &odo);
    ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());
    if (i % 7 == 3) ASSERT_TRUE(Publish(bus, "SLAMD_ODOMETRY", odo).ok());  // duplicate
    if (i >= 21 && i % 5 == 0) {
      slamd::loop_closure_t lc;
      ToLcm(LoopClosureMeasurement{i,
                                   "r",
                                   static_cast<std::uint64_t>(i + 1),
                                   "r",
                                   static_cast<std::uint64_t>(i + 1 - 21),
                                   truth(i + 1).Between(truth(i + 1 - 21)) *
                                       core::Pose2(n(rng), n(rng), n(rng)),
                                   Noise(3, 0.02),
                                   {}},
            &lc);
      ASSERT_TRUE(Publish(bus, "SLAMD_LOOP_CLOSURE", lc).ok());
    }
  }
}

// The reduced pose graph keeps the graph of a robot circling one ring bounded by holding its
// poses there as aliases; a restart rebuilds the same graph, aliases and published pose.
TEST(RecoveryTest, ReducedPoseGraphStaysBoundedAndRecoversExactly) {
  TempDir dir;
  InProcessBus bus;
  std::mt19937 rng(37);
  ServerParams p = Params(dir.str());
  p.estimator.reduced.distance_m = 2.0;
  core::Values before;
  std::int64_t merged = 0;
  core::Variable newest;
  {
    auto d = Daemon::Create(p, &bus).value();
    std::vector<slamd::reject_t> rejects;
    Subscription sub = CollectRejects(bus, &rejects);
    for (int k = 0; k < 400;) {
      const int next = std::min(400, k + 1 + static_cast<int>(rng() % 6));
      SendRing(bus, k, next);
      Drive(*d, rng);
      k = next;
    }
    for (const auto& r : rejects) {
      EXPECT_EQ(r.reason, slamd::reject_t::REASON_DUPLICATE) << r.detail;  // none: held already
    }
    EXPECT_TRUE(d->snapshot()->settled);
    before = Estimate(*d);
    merged = d->snapshot()->counters.merged_poses;
    ASSERT_EQ(d->snapshot()->robots.size(), 1u);
    newest = d->snapshot()->robots[0].pose;
    d->Stop();
  }
  EXPECT_GT(merged, 350);
  EXPECT_EQ(static_cast<std::int64_t>(before.size()), 401 - merged);
  auto d = Daemon::Create(p, &bus).value();
  ExpectSameValues(Estimate(*d), before, 0.0);
  EXPECT_EQ(d->snapshot()->counters.merged_poses, merged);
  ASSERT_EQ(d->snapshot()->robots.size(), 1u);
  EXPECT_LT(core::LocalCoordinates(d->snapshot()->robots[0].pose, newest).norm(), 1e-9);
}

}  // namespace
}  // namespace slamd::server
