// Separator summaries (core/marginals/separator_summary.h): the container equals the dense
// information of the joint marginal less the excluded factors' terms; and map shards that
// exchange them (DDF-SAM 2.0) reach the one big graph's optimum and marginals: two shards, and a
// chain of three where the middle one passes what it learnt from each side to the other.
#include "core/marginals/separator_summary.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <random>

#include "core/factors/between_factor.h"
#include "core/factors/linear_container_factor.h"
#include "core/factors/prior_factor.h"
#include "core/isam/isam2.h"

namespace slamd::core {
namespace separator_summary_test {

NoiseModel Sigma(double s) { return NoiseModel::Isotropic(3, s).value(); }
Key X(int robot, int pose) { return MakeKey('x', pose, static_cast<std::uint8_t>(1 + robot)); }

Pose2 Noisy(const Pose2& z, std::mt19937_64& rng, double s) {
  std::normal_distribution<double> n(0.0, s);
  return z.Retract(Vector3(n(rng), n(rng), n(rng)));
}

// Robots driving chains of Pose2 (a prior on each first pose) and closures between robots; the
// robots' own factors and initial guesses (dead reckoning), and the closures (robot_a's).
struct World {
  std::vector<FactorGraph> own;
  std::vector<Values> initial;
  std::vector<std::array<int, 2>> closure_robots;  // (robot_a, robot_b) of each closure
  std::vector<FactorPtr> closures;
};

World MakeWorld(int robots, int poses, const std::vector<std::array<int, 4>>& closures) {
  World w;
  std::mt19937_64 rng(7);
  std::map<Key, Pose2> truth;
  for (int r = 0; r < robots; ++r) {
    for (int i = 0; i < poses; ++i) {
      truth[X(r, i)] = Pose2(0.8 * i, 3.0 * r + 0.3 * std::sin(i), 0.1 * std::cos(i + r));
    }
    FactorGraph g;
    Values v;
    Pose2 x = Noisy(truth[X(r, 0)], rng, 0.01);
    g.Add(std::make_shared<PriorFactor<Pose2>>(X(r, 0), x, Sigma(0.01)));
    EXPECT_TRUE(v.Insert(X(r, 0), x).ok());
    for (int i = 1; i < poses; ++i) {
      const Pose2 z = Noisy(truth[X(r, i - 1)].Between(truth[X(r, i)]), rng, 0.05);
      g.Add(std::make_shared<BetweenFactor<Pose2>>(X(r, i - 1), X(r, i), z, Sigma(0.05)));
      x = x * z;
      EXPECT_TRUE(v.Insert(X(r, i), x).ok());
    }
    w.own.push_back(std::move(g));
    w.initial.push_back(std::move(v));
  }
  for (const auto& c : closures) {
    const Key a = X(c[0], c[1]), b = X(c[2], c[3]);
    const Pose2 z = Noisy(truth[a].Between(truth[b]), rng, 0.05);
    w.closure_robots.push_back({c[0], c[2]});
    w.closures.push_back(std::make_shared<BetweenFactor<Pose2>>(a, b, z, Sigma(0.05)));
  }
  return w;
}

std::unique_ptr<Isam2> Solver() {
  Isam2Params params;
  params.wildfire_threshold = 0.0;
  params.refine_threshold = 1e-10;  // settled to well below the tolerances checked
  return Isam2::Create(params).value();
}

void Settle(Isam2* isam) {
  const Isam2::RefineResult r = isam->Refine(10.0, 50);
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
}

// One server with every factor.
std::unique_ptr<Isam2> Central(const World& w) {
  auto isam = Solver();
  FactorGraph g;
  Values v;
  for (std::size_t r = 0; r < w.own.size(); ++r) {
    for (const FactorPtr& f : w.own[r].factors()) g.Add(f);
    for (Key k : w.initial[r].keys()) EXPECT_TRUE(v.Insert(k, w.initial[r].Get(k)).ok());
  }
  for (const FactorPtr& f : w.closures) g.Add(f);
  EXPECT_TRUE(isam->Update(g, v).status.ok());
  Settle(isam.get());
  return isam;
}

void AddShared(KeyVector* shared, const KeyVector& keys) {
  for (Key k : keys) {
    if (std::find(shared->begin(), shared->end(), k) == shared->end()) shared->push_back(k);
  }
}

// A shard per robot: its robot's factors and the closures whose robot_a it is (a foreign pose
// placed by the closure); what each neighbour sent (the factor and its index in the solver);
// the keys it shares with each neighbour: both ends of its closures to that neighbour's robot,
// and the keys of what that neighbour sent.
struct Shard {
  std::unique_ptr<Isam2> isam;
  std::map<int, FactorPtr> received;
  std::map<int, int> received_index;
  std::map<int, KeyVector> shared;
  KeyVector closure_keys;  // both ends of its own closures
};

std::vector<Shard> MakeShards(const World& w) {
  std::vector<Shard> shards(w.own.size());
  for (std::size_t r = 0; r < w.own.size(); ++r) {
    shards[r].isam = Solver();
    FactorGraph g = w.own[r];
    Values v = w.initial[r];
    for (std::size_t c = 0; c < w.closures.size(); ++c) {
      const auto [ra, rb] = w.closure_robots[c];
      const Key ka = w.closures[c]->keys()[0], kb = w.closures[c]->keys()[1];
      if (ra != static_cast<int>(r)) continue;
      AddShared(&shards[r].shared[rb], {ka, kb});
      AddShared(&shards[r].closure_keys, {ka, kb});
      g.Add(w.closures[c]);
      if (!v.Contains(kb)) {
        EXPECT_TRUE(v.Insert(kb, *w.closures[c]->Predict(0, v.Get(ka))).ok());
      }
    }
    EXPECT_TRUE(shards[r].isam->Update(g, v).status.ok());
    Settle(shards[r].isam.get());
  }
  return shards;
}

void Apply(const FactorPtr& summary, int from, Shard* shard);

// Shard `from` sends `to` its summary on what they share, less what `to` sent it (DDF-SAM 2.0);
// `to` replaces the one it had.
void Send(std::vector<Shard>& shards, int from, int to) {
  Shard& s = shards[from];
  Shard& t = shards[to];
  if (s.shared[to].empty()) return;
  std::vector<FactorPtr> excluded;
  if (s.received.contains(to)) excluded.push_back(s.received[to]);
  Isam2Marginals marginals(s.isam.get());
  const Result<FactorPtr> summary = SeparatorSummary(*s.isam, marginals, s.shared[to], excluded);
  ASSERT_TRUE(summary.ok()) << summary.status().ToString();
  ASSERT_NE(*summary, nullptr);
  Apply(*summary, from, &t);
}

// Shard t replaces what shard `from` sent it by `summary`.
void Apply(const FactorPtr& summary, int from, Shard* shard) {
  Shard& t = *shard;
  const auto& container = static_cast<const LinearContainerFactor&>(*summary);
  FactorGraph g;
  g.Add(summary);
  Values v;
  for (std::size_t i = 0; i < container.keys().size(); ++i) {
    const Key k = container.keys()[i];
    if (!t.isam->linearization_point().Contains(k)) {
      ASSERT_TRUE(v.Insert(k, container.linearization_point()[i]).ok());
    }
  }
  Isam2UpdateOptions options;
  if (t.received_index.contains(from)) options.remove_factors = {t.received_index[from]};
  const Isam2Result r = t.isam->Update(g, v, options);
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  AddShared(&t.shared[from], ToKeyVector(container.keys()));
  t.received[from] = summary;
  t.received_index[from] = r.new_factor_indices[0];
  Settle(t.isam.get());
}

// Shard `from` sends every other shard the summary of its own factors on its boundary (the ends
// of its closures and its poses in what others sent), every summary it received taken out.
void Broadcast(std::vector<Shard>& shards, int from) {
  Shard& s = shards[from];
  KeyVector keys = s.closure_keys, beyond;
  std::vector<FactorPtr> excluded;
  for (const auto& [other, f] : s.received) {
    excluded.push_back(f);
    for (Key k : f->keys()) {
      if (KeyRobot(k) == from + 1) AddShared(&keys, {k});
    }
  }
  for (const FactorPtr& f : excluded) {
    for (Key k : f->keys()) {
      if (std::find(keys.begin(), keys.end(), k) == keys.end()) AddShared(&beyond, {k});
    }
  }
  const int kept = static_cast<int>(keys.size());
  if (kept == 0) return;
  keys.insert(keys.end(), beyond.begin(), beyond.end());
  Isam2Marginals marginals(s.isam.get());
  const Result<FactorPtr> summary =
      SeparatorSummary(*s.isam, marginals, keys, excluded, {.kept_keys = kept});
  ASSERT_TRUE(summary.ok()) << summary.status().ToString();
  ASSERT_NE(*summary, nullptr);
  EXPECT_EQ((*summary)->keys().size(), static_cast<std::size_t>(kept));
  for (std::size_t t = 0; t < shards.size(); ++t) {
    if (static_cast<int>(t) != from) Apply(*summary, from, &shards[t]);
  }
}

// Every shard's own poses (and the foreign ones it holds) against the central estimate, and its
// own poses' marginals against the central marginals.
void ExpectCentral(std::vector<Shard>& shards, Isam2* central, double tol) {
  Isam2Marginals central_marginals(central);
  for (std::size_t r = 0; r < shards.size(); ++r) {
    Isam2& isam = *shards[r].isam;
    Isam2Marginals marginals(&isam);
    for (Key k : isam.linearization_point().keys()) {
      const Eigen::VectorXd d =
          LocalCoordinates(central->CalculateEstimate(k), isam.CalculateEstimate(k));
      EXPECT_LT(d.cwiseAbs().maxCoeff(), tol) << "shard " << r << " " << KeyToString(k);
      if (KeyRobot(k) != r + 1) continue;
      Eigen::MatrixXd c, cc;
      ASSERT_TRUE(marginals.Marginal(k, Isam2Marginals::Frame::kEstimate, &c).ok());
      ASSERT_TRUE(central_marginals.Marginal(k, Isam2Marginals::Frame::kEstimate, &cc).ok());
      EXPECT_LT((c - cc).cwiseAbs().maxCoeff(), tol * cc.cwiseAbs().maxCoeff())
          << "shard " << r << " " << KeyToString(k);
    }
  }
}

TEST(SeparatorSummary, IsTheJointInformationLessTheExcludedFactors) {
  const World w = MakeWorld(2, 6, {{0, 2, 1, 3}, {0, 5, 1, 5}});
  const auto central = Central(w);
  Isam2Marginals marginals(central.get());
  const KeyVector keys = {X(0, 2), X(1, 3), X(0, 5), X(1, 5)};
  std::vector<Variable> at;
  for (Key k : keys) at.push_back(central->CalculateEstimate(k));
  Eigen::MatrixXd cov;
  ASSERT_TRUE(marginals.JointMarginal(keys, Isam2Marginals::Frame::kEstimate, &cov).ok());

  const Result<FactorPtr> all = SeparatorSummary(keys, at, cov, {});
  ASSERT_TRUE(all.ok()) << all.status().ToString();
  const auto& c = static_cast<const LinearContainerFactor&>(**all);
  const Eigen::MatrixXd information = cov.inverse();
  EXPECT_LT((c.A().transpose() * c.A() - information).cwiseAbs().maxCoeff(),
            1e-8 * information.cwiseAbs().maxCoeff());
  EXPECT_LT(c.b().cwiseAbs().maxCoeff(), 1e-12);

  // Without the closure (0,5)-(1,5): its HᵀH and Hᵀr taken out, in its keys' columns.
  const FactorPtr closure = w.closures[1];
  const Result<FactorPtr> less = SeparatorSummary(keys, at, cov, std::span(&closure, 1));
  ASSERT_TRUE(less.ok()) << less.status().ToString();
  const auto& l = static_cast<const LinearContainerFactor&>(**less);
  Values v;
  for (std::size_t i = 0; i < keys.size(); ++i) ASSERT_TRUE(v.Insert(keys[i], at[i]).ok());
  LinearizedFactor lf;
  closure->Linearize(v, &lf);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3, 12);
  H.middleCols(6, 3) = lf.Block(0);
  H.middleCols(9, 3) = lf.Block(1);
  const Eigen::MatrixXd expected = information - H.transpose() * H;
  EXPECT_LT((l.A().transpose() * l.A() - expected).cwiseAbs().maxCoeff(),
            1e-8 * information.cwiseAbs().maxCoeff());
  const Eigen::VectorXd g = -H.transpose() * lf.Rhs();
  EXPECT_LT((l.A().transpose() * l.b() - g).cwiseAbs().maxCoeff(), 1e-8 * (1.0 + g.norm()));
}

TEST(SeparatorSummary, RejectsWhatDoesNotFit) {
  const KeyVector keys = {X(0, 0)};
  const std::vector<Variable> at = {Pose2()};
  const Eigen::MatrixXd id = Eigen::MatrixXd::Identity(3, 3);
  EXPECT_EQ(SeparatorSummary(keys, at, Eigen::MatrixXd::Identity(4, 4), {}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(SeparatorSummary(keys, at, -id, {}).status().code(), StatusCode::kFailedPrecondition);
  const FactorPtr elsewhere =
      std::make_shared<BetweenFactor<Pose2>>(X(0, 0), X(0, 1), Pose2(), Sigma(1.0));
  const Result<FactorPtr> r = SeparatorSummary(keys, at, id, std::span(&elsewhere, 1));
  EXPECT_EQ(r.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("x"), std::string::npos);
  EXPECT_EQ(SeparatorSummary(keys, at, id, {}, {.rank_tolerance = 0.0}).status().code(),
            StatusCode::kInvalidArgument);
  // A prior that says all there is: nothing is left.
  const FactorPtr prior = std::make_shared<PriorFactor<Pose2>>(X(0, 0), Pose2(), Sigma(1.0));
  const Result<FactorPtr> none = SeparatorSummary(keys, at, id, std::span(&prior, 1));
  ASSERT_TRUE(none.ok()) << none.status().ToString();
  EXPECT_EQ(*none, nullptr);
}

TEST(SeparatorSummary, TwoShardsReachTheCentralOptimumAndMarginals) {
  const World w = MakeWorld(2, 30, {{0, 5, 1, 7}, {0, 20, 1, 18}, {1, 28, 0, 29}});
  const auto central = Central(w);
  std::vector<Shard> shards = MakeShards(w);
  for (int round = 0; round < 10; ++round) {
    Send(shards, 0, 1);
    Send(shards, 1, 0);
  }
  ExpectCentral(shards, central.get(), 1e-6);
}

TEST(SeparatorSummary, AChainOfThreeShardsPassesInformationThrough) {
  // Shards 0 and 2 share nothing: what each knows reaches the other through shard 1.
  const World w = MakeWorld(3, 25, {{0, 4, 1, 6}, {1, 20, 0, 22}, {2, 10, 1, 12}, {1, 24, 2, 23}});
  const auto central = Central(w);
  std::vector<Shard> shards = MakeShards(w);
  for (int round = 0; round < 12; ++round) {
    Send(shards, 0, 1);
    Send(shards, 2, 1);
    Send(shards, 1, 0);
    Send(shards, 1, 2);
  }
  ExpectCentral(shards, central.get(), 1e-6);
}

TEST(SeparatorSummary, OwnSummariesToEveryShardAreExactAroundACycle) {
  // Three shards closing loops with each other: each one's own factors reach the others once.
  const World w = MakeWorld(3, 20, {{0, 4, 1, 5}, {1, 12, 2, 11}, {2, 17, 0, 16}, {0, 9, 2, 8}});
  const auto central = Central(w);
  std::vector<Shard> shards = MakeShards(w);
  for (int round = 0; round < 10; ++round) {
    for (int s = 0; s < 3; ++s) Broadcast(shards, s);
  }
  ExpectCentral(shards, central.get(), 1e-6);
}

TEST(SeparatorSummary, KeepsOnlyKeysLeftWithNothingElse) {
  const World w = MakeWorld(2, 6, {{0, 2, 1, 3}});
  const auto central = Central(w);
  Isam2Marginals marginals(central.get());
  // The closure is the only factor on r1:x3 besides r1's chain: taking it out leaves information
  // on r1:x3, so it cannot be dropped.
  const KeyVector keys = {X(0, 2), X(1, 3)};
  const FactorPtr closure = w.closures[0];
  const Result<FactorPtr> bad =
      SeparatorSummary(*central, marginals, keys, std::span(&closure, 1), {.kept_keys = 1});
  EXPECT_EQ(bad.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(SeparatorSummary(*central, marginals, keys, {}, {.kept_keys = 3}).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace separator_summary_test
}  // namespace slamd::core
