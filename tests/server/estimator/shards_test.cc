// Map shards at the estimator (docs/SCALING.md): shards that own some robots each and exchange
// summaries (Estimator::ShardSummary, applied as shard_summary_t) reach the estimate and the
// marginals of one estimator that has every message; a summary replaces the one before it, waits
// for a pose of its own shard that has not arrived, and is refused by another shard.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "server/estimator/estimator.h"
#include "server/messages/inbound.h"
#include "server/snapshot/state_codec.h"
#include "tests/server/estimator/estimator_test_messages.h"

namespace slamd::server::shards_test {

using core::Pose2;
using estimator_test::Loop;
using estimator_test::Odo;
using estimator_test::PoseOf;
using estimator_test::Prior;

constexpr int kPoses = 20;

// Robots r0.. drive parallel lines 3 m apart; inter-robot closures, each pair of robots `pairs`,
// at a few poses. Measurements carry noise, so the closures pull.
std::vector<Inbound> World(int robots, const std::vector<std::pair<int, int>>& pairs) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 0.05);
  const auto noisy = [&](const Pose2& z) {
    return z.Retract(core::Vector3(n(rng), n(rng), n(rng)));
  };
  const auto truth = [](int r, int i) { return Pose2(1.0 * i, 3.0 * r, 0.0); };
  std::vector<Inbound> out;
  for (int r = 0; r < robots; ++r) {
    const std::string name = "r" + std::to_string(r);
    out.push_back(Prior(name, 0, truth(r, 0)));
    for (int i = 0; i + 1 < kPoses; ++i) {
      out.push_back(Odo(name, i, i + 1, noisy(truth(r, i).Between(truth(r, i + 1)))));
    }
  }
  for (const auto& [a, b] : pairs) {
    for (const int i : {4, 11, 18}) {
      const int j = a < b ? i + 1 : i - 1;  // b->a closures name other poses than a->b ones
      out.push_back(Loop("r" + std::to_string(a), i, "r" + std::to_string(b), j,
                         noisy(truth(a, i).Between(truth(b, j)))));
    }
  }
  return out;
}

std::unique_ptr<Estimator> Make(const ShardMap& shards = {}) {
  core::Isam2Params isam2;
  isam2.refine_threshold = 1e-10;  // settled well below the tolerances checked
  return Estimator::Create({.chi2_interval_s = 0.0, .shards = shards}, isam2).value();
}

ShardMap Shards(const std::string& self, int n) {
  ShardMap m{.self = self};
  for (int s = 0; s < n; ++s)
    m.shards.push_back({"S" + std::to_string(s), {"r" + std::to_string(s)}});
  return m;
}

// What a shard takes of `messages` (the daemon's intake filter).
std::vector<Inbound> ForShard(const ShardMap& shards, const std::vector<Inbound>& messages) {
  std::vector<Inbound> out;
  for (const Inbound& in : messages) {
    const bool take = VisitSpec(in, [&](auto spec, const auto& m) {
      return ForThisShard<typename decltype(spec)::type>(shards, m);
    });
    if (take) out.push_back(in);
  }
  return out;
}

void Settle(Estimator& e, const std::string& what) {
  const auto r = e.Refine(10.0, 100);
  EXPECT_TRUE(r.status.ok()) << what << ": " << r.status.ToString();
}

// One round: every shard sends every other its summary, which that one applies.
void Exchange(std::vector<std::unique_ptr<Estimator>>& shards) {
  for (std::size_t s = 0; s < shards.size(); ++s) {
    const auto summary = shards[s]->ShardSummary(0);
    ASSERT_TRUE(summary.ok()) << summary.status().ToString();
    if (!summary->has_value()) continue;
    for (std::size_t t = 0; t < shards.size(); ++t) {
      if (s == t) continue;
      ShardSummaryMessage m = **summary;
      m.to_shard = "S" + std::to_string(t);
      const ProcessResult r = shards[t]->Process({Inbound{m, 0}});
      ASSERT_TRUE(r.status.ok()) << r.status.ToString();
      ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
      Settle(*shards[t], "shard " + std::to_string(t) + " after a summary");
    }
  }
}

// Each shard's own robot against the central estimator: poses and marginals.
void ExpectCentral(std::vector<std::unique_ptr<Estimator>>& shards, Estimator& central,
                   double tol) {
  for (std::size_t s = 0; s < shards.size(); ++s) {
    const std::string robot = "r" + std::to_string(s);
    for (int i = 0; i < kPoses; ++i) {
      estimator_test::ExpectNear(PoseOf(*shards[s], robot, i), PoseOf(central, robot, i), tol);
      Eigen::MatrixXd c, cc;
      const core::Key ks = *shards[s]->KeyOf({robot, KeyKind::kPose, std::uint64_t(i)});
      const core::Key kc = *central.KeyOf({robot, KeyKind::kPose, std::uint64_t(i)});
      ASSERT_TRUE(shards[s]->Marginal(ks, &c).ok());
      ASSERT_TRUE(central.Marginal(kc, &cc).ok());
      EXPECT_LT((c - cc).cwiseAbs().maxCoeff(), tol * cc.cwiseAbs().maxCoeff())
          << robot << " " << i;
    }
  }
}

// `n` shards fed `world` and `then` (after `rounds` exchanges), exchanging `rounds` more times,
// against one estimator fed the same.
void RunShards(int n, const std::vector<Inbound>& world, int rounds,
               const std::vector<Inbound>& then = {}) {
  auto central = Make();
  ASSERT_TRUE(central->Process(world).status.ok());
  Settle(*central, "central");
  std::vector<std::unique_ptr<Estimator>> shards;
  for (int s = 0; s < n; ++s) {
    const ShardMap map = Shards("S" + std::to_string(s), n);
    shards.push_back(Make(map));
    const ProcessResult r = shards.back()->Process(ForShard(map, world));
    ASSERT_TRUE(r.status.ok());
    ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
    Settle(*shards.back(), "shard " + std::to_string(s));
  }
  for (int k = 0; k < rounds; ++k) Exchange(shards);
  if (!then.empty()) {
    ASSERT_TRUE(central->Process(then).rejections.empty());
    Settle(*central, "central");
    for (int s = 0; s < n; ++s) {
      const ProcessResult r =
          shards[s]->Process(ForShard(Shards("S" + std::to_string(s), n), then));
      ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
    }
    for (int k = 0; k < rounds; ++k) Exchange(shards);
  }
  ExpectCentral(shards, *central, 1e-6);
}

TEST(Shards, TwoShardsEqualOneEstimator) { RunShards(2, World(2, {{0, 1}, {1, 0}}), 10); }

TEST(Shards, AChainOfThreeShardsEqualsOneEstimator) {
  RunShards(3, World(3, {{0, 1}, {2, 1}}), 12);
}

// No closure between the robots: what ties their maps together is the landmarks of the shared
// map that both see (bearing and range), between their lines. The shards find them from each
// other's landmark lists, then summarise onto them.
std::vector<Inbound> SharedLandmarkWorld(int robots) {
  std::vector<Inbound> out = World(robots, {});
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 0.02);
  for (int r = 0; r < robots; ++r) {
    for (int i = 0; i < kPoses; ++i) {
      for (int k = 0; k < 9; ++k) {  // landmark k at (2k + 0.5, 1.5 + 3 (k % (robots - 1)))
        const double x = 2.0 * k + 0.5, y = 1.5 + 3.0 * (k % std::max(1, robots - 1));
        const double dx = x - i, dy = y - 3.0 * r;
        if (std::abs(dx) > 1.6 || std::abs(dy) > 2.0) continue;
        out.push_back(estimator_test::Landmark(
            "r" + std::to_string(r), i, 100 + k, std::atan2(dy, dx) + n(rng),
            std::hypot(dx, dy) + n(rng), LandmarkNamespace::kMap));
      }
    }
  }
  return out;
}

TEST(Shards, LandmarksOfTheSharedMapSeenFromTwoShardsEqualOneEstimator) {
  RunShards(2, SharedLandmarkWorld(2), 10);
}

TEST(Shards, LandmarksOfTheSharedMapAcrossAChainOfThreeShardsEqualOneEstimator) {
  RunShards(3, SharedLandmarkWorld(3), 12);
}

// A retracted inter-shard closure: the pose it named stays shared (the other shard holds it
// through the summaries), and the shards end at the estimate without it.
TEST(Shards, ARetractedClosureBetweenShardsLeavesTheOneEstimatorsAnswer) {
  RunShards(2, World(2, {{0, 1}}), 10,
            {estimator_test::Remove(RemoveTarget::kLoopClosure, "r0", 11, "r1", 12)});
}

// The boundary is part of the state: a restored shard still shares the pose of a closure it
// retracted (which the other shard holds through its summaries).
TEST(Shards, TheBoundaryOutlivesARetractionAndASnapshot) {
  const std::vector<Inbound> world = World(2, {{0, 1}});
  std::vector<std::unique_ptr<Estimator>> shards;
  for (int s = 0; s < 2; ++s) {
    shards.push_back(Make(Shards("S" + std::to_string(s), 2)));
    ASSERT_TRUE(shards.back()
                    ->Process(ForShard(Shards("S" + std::to_string(s), 2), world))
                    .rejections.empty());
  }
  Exchange(shards);
  Exchange(shards);
  const ProcessResult r =
      shards[0]->Process({estimator_test::Remove(RemoveTarget::kLoopClosure, "r0", 11, "r1", 12)});
  ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
  const auto before = shards[0]->ShardSummary(0);
  ASSERT_TRUE(before.ok() && before->has_value());
  EXPECT_EQ((*before)->keys.size(), 6u);  // r0:11 and r1:12 still shared
  JournalPosition position;
  const core::Result<EstimatorState> state =
      DecodeState(EncodeState(shards[0]->ExportState(), {}), &position);
  ASSERT_TRUE(state.ok()) << state.status().ToString();
  core::Isam2Params isam2;
  isam2.refine_threshold = 1e-10;
  auto restored =
      Estimator::Restore({.chi2_interval_s = 0.0, .shards = Shards("S0", 2)}, isam2, state.value())
          .value();
  const auto after = restored->ShardSummary(0);
  ASSERT_TRUE(after.ok() && after->has_value());
  EXPECT_EQ((*after)->keys, (*before)->keys);
}

// A crash after a retraction and before the next snapshot: the journal replayed from the last
// snapshot (closures, the summaries received, the retraction; no summary is computed meanwhile)
// gives the boundary the live run had, so the retracted closure's poses stay shared.
TEST(Shards, AReplayedRetractionKeepsTheBoundaryOfTheLiveRun) {
  const std::vector<Inbound> world = World(2, {{0, 1}});
  const ShardMap s0 = Shards("S0", 2), s1 = Shards("S1", 2);
  auto live = Make(s0), other = Make(s1);
  std::vector<Inbound> closures, journal;  // S0's closures; what S0 takes after its snapshot
  std::vector<Inbound> before_closures;
  for (const Inbound& in : ForShard(s0, world)) {
    (std::holds_alternative<LoopClosureMeasurement>(in.measurement) ? closures : before_closures)
        .push_back(in);
  }
  ASSERT_FALSE(closures.empty());
  ASSERT_TRUE(live->Process(before_closures).rejections.empty());
  ASSERT_TRUE(other->Process(ForShard(s1, world)).rejections.empty());
  const EstimatorState snapshot = live->ExportState();
  const auto take = [&](const std::vector<Inbound>& in) {
    const ProcessResult r = live->Process(in);
    ASSERT_TRUE(r.rejections.empty()) << r.rejections[0].verdict.message;
    journal.insert(journal.end(), in.begin(), in.end());
  };
  ASSERT_NO_FATAL_FAILURE(take(closures));
  for (int round = 0; round < 2; ++round) {
    const auto mine = live->ShardSummary(0);
    ASSERT_TRUE(mine.ok() && mine->has_value());
    ShardSummaryMessage to_other = **mine;
    to_other.to_shard = "S1";
    ASSERT_TRUE(other->Process({Inbound{to_other, 0}}).rejections.empty());
    const auto theirs = other->ShardSummary(0);
    ASSERT_TRUE(theirs.ok() && theirs->has_value());
    ShardSummaryMessage to_live = **theirs;
    to_live.to_shard = "S0";
    ASSERT_NO_FATAL_FAILURE(take({Inbound{to_live, 0}}));
  }
  ASSERT_NO_FATAL_FAILURE(
      take({estimator_test::Remove(RemoveTarget::kLoopClosure, "r0", 11, "r1", 12)}));
  const auto before = live->ShardSummary(0);
  ASSERT_TRUE(before.ok() && before->has_value());

  core::Isam2Params isam2;
  isam2.refine_threshold = 1e-10;
  auto replayed = Estimator::Restore({.chi2_interval_s = 0.0, .shards = s0}, isam2, snapshot);
  ASSERT_TRUE(replayed.ok()) << replayed.status().ToString();
  for (const Inbound& in : journal) {  // one message per update, as a journal replays them
    ASSERT_TRUE(replayed.value()->Process({in}).rejections.empty());
  }
  const auto after = replayed.value()->ShardSummary(0);
  ASSERT_TRUE(after.ok() && after->has_value()) << after.status().ToString();
  EXPECT_EQ((*after)->keys, (*before)->keys);
}

// Every shard closes loops with every other: no shard's information is counted twice.
TEST(Shards, FourShardsClosingLoopsWithEachOtherEqualOneEstimator) {
  RunShards(4, World(4, {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 2}, {3, 1}}), 12);
}

TEST(Shards, ShardsTakeTheirRobotsAndTheirClosures) {
  const ShardMap a = Shards("S0", 2), b = Shards("S1", 2);
  const std::vector<Inbound> world = World(2, {{0, 1}});
  const std::vector<Inbound> for_a = ForShard(a, world), for_b = ForShard(b, world);
  EXPECT_EQ(for_a.size() + for_b.size(), world.size());
  EXPECT_EQ(for_a.size(), kPoses + 3u);  // r0's prior and odometry, and its closures to r1
  // A robot no shard lists is the first shard's.
  EXPECT_EQ(a.OwnerOf("stranger"), "S0");
  EXPECT_TRUE(a.Owns("stranger"));
  EXPECT_FALSE(b.Owns("stranger"));
  // r1's poses in S0: shared poses, placed by the closures, not a robot S0 publishes.
  auto e = Make(a);
  ASSERT_TRUE(e->Process(for_a).status.ok());
  EXPECT_TRUE(e->KeyOf({"r1", KeyKind::kPose, 5}).has_value());
  EXPECT_FALSE(e->KeyOf({"r1", KeyKind::kPose, 4}).has_value());
  EXPECT_EQ(e->snapshot()->robots.size(), 1u);
}

TEST(Shards, ASummaryReplacesTheLastWaitsForItsPosesAndGoesToItsShard) {
  const std::vector<Inbound> world = World(2, {{0, 1}});
  auto s0 = Make(Shards("S0", 2));
  auto s1 = Make(Shards("S1", 2));
  ASSERT_TRUE(s0->Process(ForShard(Shards("S0", 2), world)).status.ok());
  auto summary = s0->ShardSummary(0);
  ASSERT_TRUE(summary.ok() && summary->has_value());
  (*summary)->to_shard = "S1";
  EXPECT_EQ((*summary)->keys.size(), 6u);  // both ends of 3 closures
  // S1 has none of r1's poses yet: held until they come.
  ProcessResult r = s1->Process({Inbound{**summary, 0}});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(s1->held_messages(), 1);
  r = s1->Process(ForShard(Shards("S1", 2), world));
  ASSERT_TRUE(r.status.ok());
  EXPECT_EQ(s1->held_messages(), 0);
  const std::int64_t factors = s1->snapshot()->num_factors;
  EXPECT_EQ(factors, kPoses + 1);  // its prior, odometry, and the summary
  // The next summary replaces it.
  r = s1->Process({Inbound{**summary, 0}});
  EXPECT_TRUE(r.rejections.empty());
  EXPECT_EQ(r.applied, 1);
  EXPECT_EQ(s1->snapshot()->num_factors, factors);
  // Another shard refuses it; a summary between shards with nothing shared is none.
  auto other = Make(Shards("S0", 2));
  r = other->Process({Inbound{**summary, 0}});
  ASSERT_EQ(r.rejections.size(), 1u);
  EXPECT_NE(r.rejections[0].verdict.message.find("not this slamd's shard"), std::string::npos);
  const auto none = Make(Shards("S0", 2))->ShardSummary(0);
  ASSERT_TRUE(none.ok());
  EXPECT_FALSE(none->has_value());
  EXPECT_FALSE(Make()->ShardSummary(0).ok());  // not a shard
}

}  // namespace slamd::server::shards_test
