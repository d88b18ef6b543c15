// Background relinearisation through the estimator: rebuilds that take what came meanwhile,
// catch-up rounds, replays of the journal's rounds, and swaps (server/estimator/estimator.h).
#include "server/estimator/background_rebuild.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <map>
#include <numeric>
#include <set>
#include <thread>

#include "server/estimator/estimator.h"
#include "tests/server/estimator/estimator_test_messages.h"

namespace slamd::server {
namespace {

using core::Pose2;
using namespace estimator_test;  // NOLINT: the shared messages and checks

// Background relinearisation (EstimatorParams::background_relinearization_above): updates due
// to relinearise more than 2 variables defer it and start a rebuild; each rebuild is finished
// only after more messages came (new poses, loop closures, a removal of a loop closure from
// before the rebuild started, a loop closure added and removed at once), so the catch-up has
// all of that to take. A removal after a swap finds its factor in the new solver. Settled, the
// result equals an estimator that relinearised every time in the update and never had the
// removed loop closures. Parameterised: live (the helper's rounds, if any, and the swap's
// catch-up), and replaying with catch-up rounds of two logged updates each (as a journal would
// give them), so that removals are mapped across rounds and within one.
class BackgroundRebuildTest : public ::testing::TestWithParam<bool> {};

TEST_P(BackgroundRebuildTest, TakesWhatCameMeanwhileAndSettlesOnTheSameOptimum) {
  const bool replay = GetParam();
  auto rebuilt = Make({.chi2_interval_s = 0.0, .background_relinearization_above = 2});
  auto inline_only = Make({.chi2_interval_s = 0.0, .background_relinearization_above = 0});
  rebuilt->SetReplaying(replay);
  int deferred = 0;  // updates of `rebuilt` that deferred a relinearisation
  int logged = 0;    // its updates since the rebuild in flight started
  bool in_flight = false;
  auto both = [&](std::vector<Inbound> batch) {
    const ProcessResult a = rebuilt->Process(batch);
    const ProcessResult b = inline_only->Process(batch);
    EXPECT_TRUE(a.status.ok()) << a.status.ToString();
    EXPECT_TRUE(b.status.ok()) << b.status.ToString();
    EXPECT_TRUE(a.rejections.empty()) << a.rejections[0].verdict.message;
    for (const core::Isam2Result& u : a.updates) {
      logged += in_flight;
      if (u.relinearization_deferred > 0 && !in_flight) in_flight = true, logged = 0;
      deferred += u.relinearization_deferred > 0;
    }
  };
  int swaps = 0, rounds = 0;
  auto finish = [&] {
    std::vector<int> replay_rounds;
    for (int left = logged; replay && left >= 2; left -= 2) replay_rounds.push_back(2);
    const core::Result<bool> swapped = rebuilt->FinishRebuild(replay_rounds);
    ASSERT_TRUE(swapped.ok()) << swapped.status().ToString();
    EXPECT_TRUE(swapped.value());
    if (replay) {
      EXPECT_EQ(rebuilt->last_swap_rounds(), replay_rounds);
    }
    rounds += static_cast<int>(rebuilt->last_swap_rounds().size());
    ++swaps;
    // The swap's catch-up may defer and start the next rebuild.
    in_flight = rebuilt->Rebuilding(), logged = 0;
  };
  both({Prior("r", 0, Pose2())});
  // Loop closures ~0.8 m and 0.3 rad off what the odometry says: the estimate keeps moving by
  // more than the thresholds (and there is one optimum, whichever way it is approached).
  Pose2 six = Pose2();
  for (int k = 0; k < 6; ++k) six = six * kStep;
  const Pose2 loop = six.Inverse() * Pose2(0.6, -0.5, 0.3);
  for (int i = 0; i < 60; ++i) {
    std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
    if (i >= 6 && i % 3 == 0) batch.push_back(Loop("r", i + 1, "r", i - 5, loop));
    // A loop closure from before, removed while a rebuild may be in flight.
    if (i >= 12 && i % 9 == 0) {
      const int j = i - 6 - (i - 6) % 3;
      batch.push_back(Remove(RemoveTarget::kLoopClosure, "r", j + 1, "r", j - 5));
    }
    // Loop closures added and at once removed (updates likely in one round); the second takes
    // the solver slot the first had.
    if (i % 7 == 5) {
      for (int back : {4, 3}) {
        batch.push_back(Loop("r", i + 1, "r", i - back, Pose2(2.0, 0.0, 0.5)));
        batch.push_back(Remove(RemoveTarget::kLoopClosure, "r", i + 1, "r", i - back));
      }
    }
    both(batch);
    if (i % 4 == 3 && rebuilt->Rebuilding()) finish();
  }
  EXPECT_GT(swaps, 2);
  if (replay) {
    EXPECT_GT(rounds, 2);
  }
  EXPECT_EQ(rebuilt->snapshot()->counters.rebuilds, swaps);
  EXPECT_EQ(inline_only->snapshot()->counters.rebuilds, 0);
  EXPECT_EQ(rebuilt->snapshot()->num_factors, inline_only->snapshot()->num_factors);
  // A removal of a measurement applied before the swaps.
  both({Remove(RemoveTarget::kLoopClosure, "r", 58, "r", 52)});
  // Each rebuild starts nearer the optimum.
  for (int k = 0; k < 20 && rebuilt->Rebuilding(); ++k) finish();
  ASSERT_FALSE(rebuilt->Rebuilding());
  EXPECT_GE(deferred, swaps - 20);
  ASSERT_TRUE(rebuilt->Refine(10.0).converged);
  ASSERT_TRUE(inline_only->Refine(10.0).converged);
  for (int i = 0; i <= 60; ++i) {
    ExpectNear(PoseOf(*rebuilt, "r", i), PoseOf(*inline_only, "r", i), 1e-6);
  }
  EXPECT_NEAR(rebuilt->snapshot()->chi2, inline_only->snapshot()->chi2,
              1e-8 * inline_only->snapshot()->chi2);
  EXPECT_FALSE(rebuilt->FinishRebuild().value());  // none in flight
}

INSTANTIATE_TEST_SUITE_P(LiveAndReplayedRounds, BackgroundRebuildTest, ::testing::Bool());

// A rebuild of a larger map takes long enough for many updates to be logged meanwhile: its
// helper catches up in rounds. An estimator replaying the same batches, with the same swaps and
// rounds (as the journal gives them), ends bit for bit where the live one did. Whether the rounds
// take any update depends on the threads' timing (on a loaded machine the estimator thread may
// log nothing while the helper builds): the live stream is run again, up to three times, until
// they have.
TEST(EstimatorTest, HelperCatchUpRoundsReplayBitForBit) {
  const EstimatorParams params = {.chi2_interval_s = 0.0, .background_relinearization_above = 8};
  const std::vector<std::vector<Inbound>> batches = CorridorBatches(1500);
  std::unique_ptr<Estimator> live;
  std::map<size_t, std::vector<int>> swaps;  // after batch k: the swap's rounds
  int rounds = 0;
  for (int stream = 0; stream < 3 && rounds == 0; ++stream) {
    live = Make(params);
    swaps.clear();
    for (size_t k = 0; k < batches.size(); ++k) {
      ASSERT_TRUE(live->Process(batches[k]).status.ok());
      if (!live->RebuildReady()) continue;
      ASSERT_TRUE(live->FinishRebuild().ok());
      swaps[k] = live->last_swap_rounds();
      rounds += static_cast<int>(swaps[k].size());
    }
    // How many rebuilds become ready between batches depends on the machine's speed and load;
    // one at least, waited for after the last batch if need be.
    if (swaps.empty()) {
      ASSERT_TRUE(live->Rebuilding());
      ASSERT_TRUE(live->FinishRebuild().ok());
      swaps[batches.size() - 1] = live->last_swap_rounds();
      rounds += static_cast<int>(swaps[batches.size() - 1].size());
    }
  }
  EXPECT_GT(rounds, 0);  // a 1500-pose rebuild against updates of ~50 µs
  // With rounds off the helper runs none, whatever waits; the swap takes it all.
  EstimatorParams no_rounds = params;
  no_rounds.rebuild_catch_up_rounds = 0;
  auto swap_only = Make(no_rounds);
  int swaps_without_rounds = 0;
  for (const std::vector<Inbound>& batch : batches) {
    ASSERT_TRUE(swap_only->Process(batch).status.ok());
    if (!swap_only->RebuildReady()) continue;
    ASSERT_TRUE(swap_only->FinishRebuild().ok());
    EXPECT_TRUE(swap_only->last_swap_rounds().empty());
    ++swaps_without_rounds;
  }
  if (swaps_without_rounds == 0) {
    ASSERT_TRUE(swap_only->Rebuilding());
    ASSERT_TRUE(swap_only->FinishRebuild().ok());
    EXPECT_TRUE(swap_only->last_swap_rounds().empty());
  }

  auto replayed = Make(params);
  replayed->SetReplaying(true);
  for (size_t k = 0; k < batches.size(); ++k) {
    ASSERT_TRUE(replayed->Process(batches[k]).status.ok());
    const auto it = swaps.find(k);
    if (it == swaps.end()) continue;
    const core::Result<bool> swapped = replayed->FinishRebuild(it->second);
    ASSERT_TRUE(swapped.ok() && swapped.value());
    EXPECT_EQ(replayed->last_swap_rounds(), it->second);
  }
  EXPECT_EQ(replayed->Rebuilding(), live->Rebuilding());
  for (int i = 0; i <= 1500; ++i) {
    const Pose2 a = PoseOf(*live, "r", i), b = PoseOf(*replayed, "r", i);
    ASSERT_EQ(a.x(), b.x()) << "pose " << i;
    ASSERT_EQ(a.y(), b.y()) << "pose " << i;
    ASSERT_EQ(a.theta(), b.theta()) << "pose " << i;
  }
  EXPECT_EQ(replayed->snapshot()->chi2, live->snapshot()->chi2);
  // Rounds naming more updates than were logged (recorded for another rebuild, as after a
  // snapshot recovery) are ignored: the swap takes everything.
  if (replayed->Rebuilding()) {
    const core::Result<bool> swapped = replayed->FinishRebuild(std::vector<int>{1000000});
    ASSERT_TRUE(swapped.ok() && swapped.value()) << swapped.status().ToString();
    EXPECT_TRUE(replayed->last_swap_rounds().empty());
  }
}

// The helper is ready only once it has taken everything logged: an update logged while the
// rebuild was not ready (and rounds were left) never falls to the swap, also not one logged
// during the helper's chi2 pass. Whether the rounds take any update depends on the threads'
// timing (on a loaded machine the helper may finish each rebuild before the next update): the
// stream is run again, up to three times, until they have.
TEST(EstimatorTest, SwapTakesOnlyWhatWasLoggedAfterTheRebuildWasReady) {
  const EstimatorParams params = {
      .chi2_interval_s = 1.0, .background_relinearization_above = 8, .rebuild_catch_up_rounds = 64};
  int swaps = 0, taken_by_rounds = 0;
  for (int stream = 0; stream < 3 && taken_by_rounds == 0; ++stream) {
    auto e = Make(params);
    size_t logged_before_ready = 0, logged = 0;
    for (const std::vector<Inbound>& batch : CorridorBatches(1500)) {
      const bool logs = e->Rebuilding();  // this update goes into the rebuild's log
      ASSERT_TRUE(e->Process(batch).status.ok());
      std::this_thread::sleep_for(std::chrono::microseconds(100));  // a stream, not one burst
      if (!logs) continue;
      ++logged;
      if (!e->RebuildReady()) {
        ++logged_before_ready;
        continue;
      }
      ASSERT_TRUE(e->FinishRebuild().ok());
      const std::vector<int>& rounds = e->last_swap_rounds();
      const size_t in_rounds = std::accumulate(rounds.begin(), rounds.end(), size_t{0});
      ASSERT_LT(rounds.size(), 64u);  // rounds were left: the helper stopped because nothing waited
      EXPECT_GE(in_rounds, logged_before_ready) << "swap " << swaps;
      EXPECT_LE(in_rounds, logged) << "swap " << swaps;
      taken_by_rounds += static_cast<int>(in_rounds);
      ++swaps;
      logged = logged_before_ready = 0;
    }
  }
  EXPECT_GE(swaps, 2);
  EXPECT_GT(taken_by_rounds, 0);
}

// Odometry from pose i to i + 1 and, every 10 poses, a loop closure 0.3 m off to the pose 19
// back: enough relinearisation for background rebuilds with a small limit.
std::vector<Inbound> LoopingStep(int i) {
  std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
  if (i >= 20 && i % 10 == 0) batch.push_back(Loop("r", i + 1, "r", i - 19, Pose2(0.3, 0, 0)));
  return batch;
}

// Rounds that name more updates than were logged while the rebuild ran (a swap record of another
// rebuild, as after a recovery from a snapshot) are ignored: the swap takes everything, exactly
// as a swap without rounds, and the estimator goes on.
TEST(EstimatorTest, ReplayedRoundsThatDoNotFitTheLogAreIgnored) {
  const EstimatorParams params = {.chi2_interval_s = 0.0, .background_relinearization_above = 8};
  std::vector<std::vector<Inbound>> batches = {{Prior("r", 0, Pose2())}};
  for (int i = 0; i < 400; ++i) batches.push_back(LoopingStep(i));
  // Both replay the same batches; at the first rebuild, after three more updates are logged,
  // one swaps with rounds that do not fit, the other with none.
  auto mismatched = Make(params), plain = Make(params);
  mismatched->SetReplaying(true);
  plain->SetReplaying(true);
  int logged = -1;
  for (const std::vector<Inbound>& batch : batches) {
    ASSERT_TRUE(mismatched->Process(batch).status.ok());
    ASSERT_TRUE(plain->Process(batch).status.ok());
    ASSERT_EQ(mismatched->Rebuilding(), plain->Rebuilding());
    if (logged < 0 && mismatched->Rebuilding()) logged = 0;
    if (logged >= 0 && mismatched->Rebuilding() && ++logged == 4) {
      const core::Result<bool> a = mismatched->FinishRebuild(std::vector<int>{2, 1000000});
      ASSERT_TRUE(a.ok() && a.value()) << a.status().ToString();
      EXPECT_TRUE(mismatched->last_swap_rounds().empty());
      const core::Result<bool> b = plain->FinishRebuild();
      ASSERT_TRUE(b.ok() && b.value());
    }
  }
  ASSERT_GE(logged, 4) << "no rebuild was started";
  for (int i = 0; i <= 400; ++i) {
    const Pose2 a = PoseOf(*mismatched, "r", i), b = PoseOf(*plain, "r", i);
    ASSERT_EQ(a.x(), b.x()) << "pose " << i;
    ASSERT_EQ(a.theta(), b.theta()) << "pose " << i;
  }
}

// A swapped-in rebuild hands over the status chi2 its helper computed, so the estimator thread
// does not make that pass over every factor. With nothing logged while the rebuild ran, it is
// the chi2 of the live solver right after the swap, bit for bit.
TEST(EstimatorTest, SwapHandsOverTheChi2ItsHelperComputed) {
  // chi2_interval_s so long that the estimator thread computes chi2 only at its first update.
  auto e = Make({.chi2_interval_s = 1000.0, .background_relinearization_above = 8});
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  const std::int64_t first = e->snapshot()->chi2_sequence;
  for (int i = 0; i < 400 && !e->Rebuilding(); ++i) {
    ASSERT_TRUE(e->Process(LoopingStep(i)).status.ok());
  }
  ASSERT_TRUE(e->Rebuilding());
  const std::int64_t started = e->snapshot()->update_sequence;
  EXPECT_EQ(e->snapshot()->chi2_sequence, first);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!e->RebuildReady() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const core::Result<bool> swapped = e->FinishRebuild();
  ASSERT_TRUE(swapped.ok() && swapped.value());
  EXPECT_EQ(e->snapshot()->chi2_sequence, started);
  EXPECT_GT(e->snapshot()->update_sequence, started);
  EXPECT_EQ(e->snapshot()->chi2, e->solver().Chi2());
}

// The window removes nothing while a rebuild is in flight. Once it has fallen behind (a robot
// keeps more than half of its poses one to two windows back), no rebuild starts and one in
// flight is hurried and swapped in (the daemon does that before a window pass), so the window
// goes on; caught up, rebuilds start again.
TEST(EstimatorTest, NoRebuildStartsWhileTheWindowIsBehind) {
  EstimatorParams p{.chi2_interval_s = 0.0, .background_relinearization_above = 2};
  p.window = {.keep_poses = 20, .keyframe_spacing_m = 0.0, .every_updates = 1};
  auto e = Make(p);
  ASSERT_TRUE(e->Process({Prior("r", 0, Pose2())}).status.ok());
  int i = 0;
  for (; i < 400 && !e->Rebuilding(); ++i) {
    ASSERT_TRUE(e->Process(LoopingStep(i)).status.ok());
    if (!e->Rebuilding()) (void)e->ApplyPoseWindow();
  }
  ASSERT_TRUE(e->Rebuilding());
  ASSERT_FALSE(e->WindowBehind());
  // In flight: the window waits, and falls behind once 11 of the poses 20-40 back are still
  // there (it last removed those 20 behind the rebuild's start).
  const int started = i;
  for (; !e->WindowBehind(); ++i) {
    ASSERT_LT(i, started + 60);
    ASSERT_TRUE(e->Process(LoopingStep(i)).status.ok());
    EXPECT_TRUE(e->ApplyPoseWindow().keys.empty());
  }
  EXPECT_GE(i, started + 10);
  e->HurryRebuild();
  const core::Result<bool> swapped = e->FinishRebuild();
  ASSERT_TRUE(swapped.ok() && swapped.value()) << swapped.status().ToString();
  // Behind: the updates that defer their relinearisation start no rebuild.
  int deferred = 0;
  for (int k = 0; k < 30; ++k, ++i) {
    const ProcessResult r = e->Process(LoopingStep(i));
    ASSERT_TRUE(r.status.ok());
    for (const core::Isam2Result& u : r.updates) deferred += u.relinearization_deferred > 0;
    ASSERT_FALSE(e->Rebuilding()) << "update " << i;
  }
  EXPECT_GT(deferred, 0);
  // The window catches up; then a deferral starts a rebuild again.
  EXPECT_GT(e->ApplyPoseWindow().keys.size(), 40u);
  EXPECT_FALSE(e->WindowBehind());
  for (int k = 0; k < 200 && !e->Rebuilding(); ++k, ++i) {
    ASSERT_TRUE(e->Process(LoopingStep(i)).status.ok());
    (void)e->ApplyPoseWindow();
  }
  EXPECT_TRUE(e->Rebuilding());
}

}  // namespace
}  // namespace slamd::server
