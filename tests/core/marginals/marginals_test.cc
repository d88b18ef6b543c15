#include "core/marginals/marginals.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <map>
#include <random>
#include <set>

#include "core/inference/back_substitution.h"
#include "core/inference/elimination.h"
#include "core/isam/isam2.h"
#include "core/linear/ordering.h"
#include "tests/testing/example_graphs.h"
#include "tests/testing/numerical_derivative.h"

namespace slamd::core {
namespace {

using testing::ExampleProblem;


std::unique_ptr<Isam2> MakeIsam2() {
  Result<std::unique_ptr<Isam2>> isam = Isam2::Create();
  EXPECT_TRUE(isam.ok()) << isam.status().ToString();
  return std::move(isam).value();
}

// The independent reference: Σ = (Σ_f AᵀA)⁻¹, every factor linearised at θ, dense; variable v
// (slot) at rows offsets[v].
struct DenseReference {
  std::vector<int> offsets;
  std::vector<int> dims;
  Eigen::MatrixXd sigma;

  Eigen::MatrixXd Joint(std::span<const int> vars) const {
    int n = 0;
    for (int v : vars) n += dims[v];
    Eigen::MatrixXd out(n, n);
    int oi = 0;
    for (int a : vars) {
      int oj = 0;
      for (int b : vars) {
        out.block(oi, oj, dims[a], dims[b]) = sigma.block(offsets[a], offsets[b], dims[a], dims[b]);
        oj += dims[b];
      }
      oi += dims[a];
    }
    return out;
  }
};

DenseReference Dense(const Isam2& isam) {
  const Values& theta = isam.linearization_point();
  DenseReference ref;
  for (std::size_t s = 0; s < theta.size(); ++s) ref.dims.push_back(theta.DimAt(static_cast<int>(s)));
  ref.offsets = StackedOffsets(ref.dims);
  const int n = ref.offsets.back();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  LinearizedFactor lf;
  for (const FactorPtr& f : isam.Factors()) {
    f->Linearize(theta, &lf);
    for (int i = 0; i < lf.num_keys(); ++i) {
      const int si = theta.SlotOf(f->keys()[i]);
      for (int j = 0; j < lf.num_keys(); ++j) {
        const int sj = theta.SlotOf(f->keys()[j]);
        H.block(ref.offsets[si], ref.offsets[sj], ref.dims[si], ref.dims[sj]) +=
            lf.Block(i).transpose() * lf.Block(j);
      }
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(H);
  EXPECT_EQ(llt.info(), Eigen::Success);
  ref.sigma = llt.solve(Eigen::MatrixXd::Identity(n, n));
  return ref;
}

// max |a − b| ≤ tol · max |b| (relative to the reference's largest entry).
::testing::AssertionResult RelativelyNear(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << "shape " << a.rows() << "x" << a.cols() << " vs " << b.rows()
                                         << "x" << b.cols();
  }
  const double err = (a - b).cwiseAbs().maxCoeff(), scale = b.cwiseAbs().maxCoeff();
  if (err <= tol * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "max difference " << err << " > " << tol << " * " << scale << "\n"
                                       << a << "\nvs\n" << b;
}

// The variable among 0..n-1 whose clique is deepest in the tree, and that depth (cliques on its
// path to the root, itself included).
int DeepestVariable(const BayesTree& tree, int n, int* depth) {
  int deepest = 0;
  *depth = 0;
  for (int v = 0; v < n; ++v) {
    int d = 0;
    for (int x = tree.CliqueOf(v); x != BayesTree::kNone; x = tree.clique(x).parent()) ++d;
    if (d > *depth) {
      *depth = d;
      deepest = v;
    }
  }
  return deepest;
}

bool IsAncestorOrSelf(const BayesTree& tree, int a, int c) {
  for (int x = c; x != BayesTree::kNone; x = tree.clique(x).parent()) {
    if (x == a) return true;
  }
  return false;
}

std::unique_ptr<Isam2> Solve(const ExampleProblem& p) {
  auto isam = MakeIsam2();
  for (const testing::ExampleStep& s : testing::StreamByPose(p)) EXPECT_TRUE(isam->Update(s.factors, s.values).status.ok());
  return isam;
}

class MarginalsParityTest : public ::testing::TestWithParam<int> {
 protected:
  ExampleProblem Problem() const {
    // 0: planar with landmarks, 1: spatial, 2: another planar seed.
    switch (GetParam()) {
      case 0: return testing::MakePlanarProblem(40, 8, 11);
      case 1: return testing::MakeSpatialProblem(30, 12);
      default: return testing::MakePlanarProblem(25, 12, 13);
    }
  }
};

TEST_P(MarginalsParityTest, EveryVariableMarginalEqualsTheDenseInverse) {
  auto isam = Solve(Problem());
  const DenseReference ref = Dense(*isam);
  BayesTreeMarginals marginals(&isam->tree());
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, isam->tree().NumCliques());
  Eigen::MatrixXd cov;
  for (int v = 0; v < static_cast<int>(ref.dims.size()); ++v) {
    ASSERT_TRUE(marginals.Marginal(v, &cov).ok());
    const int one[] = {v};
    EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "variable " << v;
  }
  // Fresh object, no ComputeAll: each query computes its own path.
  BayesTreeMarginals lazy(&isam->tree());
  for (int v = static_cast<int>(ref.dims.size()) - 1; v >= 0; --v) {
    ASSERT_TRUE(lazy.Marginal(v, &cov).ok());
    const int one[] = {v};
    EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "variable " << v;
  }
}

// A root's variables before anything is cached come from the root's trailing block of R alone
// (BayesTreeMarginals::RootTrailingMarginal): each equals the dense inverse, and nothing is
// cached, so a later full pass still computes the root.
TEST_P(MarginalsParityTest, RootVariablesFromTheTrailingBlockEqualTheDenseInverse) {
  auto isam = Solve(Problem());
  const BayesTree& tree = isam->tree();
  const DenseReference ref = Dense(*isam);
  BayesTreeMarginals marginals(&tree);
  Eigen::MatrixXd cov;
  int checked = 0;
  for (int root : tree.roots()) {
    const Clique& cl = tree.clique(root);
    for (int k = 0; k < cl.num_frontals(); ++k) {
      if (cl.FrontalDim() - cl.frontal_offset(k) > 12) continue;  // the general path's
      const int v = cl.frontal(k);
      ASSERT_TRUE(marginals.Marginal(v, &cov).ok());
      EXPECT_EQ(marginals.stats().cliques_computed, 1);
      const int one[] = {v};
      EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "variable " << v;
      ++checked;
    }
  }
  EXPECT_GE(checked, 2);
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, tree.NumCliques());
}

TEST_P(MarginalsParityTest, JointMarginalsEqualTheDenseInverse) {
  auto isam = Solve(Problem());
  const BayesTree& tree = isam->tree();
  const DenseReference ref = Dense(*isam);
  const int n = static_cast<int>(ref.dims.size());
  BayesTreeMarginals marginals(&tree);
  Eigen::MatrixXd cov;
  std::vector<std::vector<int>> sets;
  // Pairs in different branches (neither clique an ancestor of the other).
  int branch_pairs = 0;
  for (int a = 0; a < n && branch_pairs < 6; ++a) {
    for (int b = a + 1; b < n && branch_pairs < 6; b += 3) {
      const int ca = tree.CliqueOf(a), cb = tree.CliqueOf(b);
      if (!IsAncestorOrSelf(tree, ca, cb) && !IsAncestorOrSelf(tree, cb, ca)) {
        sets.push_back({b, a});
        ++branch_pairs;
      }
    }
  }
  ASSERT_GT(branch_pairs, 0) << "the tree has no two branches: the test would not test them";
  // A clique's frontals plus separator (the cached fast path), from a deep clique.
  for (int c : tree.TopDownOrder()) {
    const Clique& cl = tree.clique(c);
    if (cl.num_separator() >= 2) {
      std::vector<int> s(cl.separator().begin(), cl.separator().end());
      s.insert(s.begin() + 1, cl.frontal(0));
      sets.push_back(s);
    }
  }
  // Random sets of 2 to 6 variables.
  std::mt19937 rng(7);
  for (int t = 0; t < 20; ++t) {
    std::vector<int> all(n);
    for (int v = 0; v < n; ++v) all[v] = v;
    std::shuffle(all.begin(), all.end(), rng);
    all.resize(2 + t % 5);
    sets.push_back(all);
  }
  sets.push_back({0, n - 1});
  for (const auto& s : sets) {
    ASSERT_TRUE(marginals.JointMarginal(s, &cov).ok());
    EXPECT_TRUE(RelativelyNear(cov, ref.Joint(s), 1e-9)) << "set of " << s.size() << " starting at " << s[0];
  }
}

INSTANTIATE_TEST_SUITE_P(PlanarSpatial, MarginalsParityTest, ::testing::Values(0, 1, 2));

TEST(MarginalsTest, CachedResultsEqualAFreshComputationAfterEveryUpdate) {
  for (int kind = 0; kind < 2; ++kind) {
    const ExampleProblem p = kind == 0 ? testing::MakePlanarProblem(40, 8, 21) : testing::MakeSpatialProblem(30, 22);
    auto isam = MakeIsam2();
    BayesTreeMarginals cached(&isam->tree());
    int reused_steps = 0;
    const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
    for (std::size_t i = 0; i < steps.size(); ++i) {
      ASSERT_TRUE(isam->Update(steps[i].factors, steps[i].values).status.ok());
      if (i % 3 == 0) {  // some steps skipped: the cache must notice changes it did not see
        cached.ComputeAll();
        if (cached.stats().cliques_computed < isam->tree().NumCliques()) ++reused_steps;
      }
      BayesTreeMarginals fresh(&isam->tree());
      fresh.ComputeAll();
      const int n = static_cast<int>(isam->linearization_point().size());
      Eigen::MatrixXd a, b;
      for (int v = 0; v < n; ++v) {
        ASSERT_TRUE(cached.Marginal(v, &a).ok());
        ASSERT_TRUE(fresh.Marginal(v, &b).ok());
        // Reused joints may differ from fresh ones by round-off (MarginalsParams::reuse_tolerance).
        ASSERT_TRUE(RelativelyNear(a, b, 1e-10)) << "step " << i << " variable " << v;
      }
      if (i + 1 == steps.size() || i % 7 == 0) {
        const DenseReference ref = Dense(*isam);
        for (int v = 0; v < n; ++v) {
          ASSERT_TRUE(cached.Marginal(v, &a).ok());
          const int one[] = {v};
          ASSERT_TRUE(RelativelyNear(a, ref.Joint(one), 1e-9)) << "step " << i << " variable " << v;
        }
      }
    }
    EXPECT_GT(reused_steps, 0);
  }
}

TEST(MarginalsTest, NewestPoseAfterAnOdometryStepTouchesOnlyThePathToTheRoot) {
  const ExampleProblem p = testing::MakePlanarProblem(60, 0, 31);
  auto isam = MakeIsam2();
  BayesTreeMarginals marginals(&isam->tree());
  Eigen::MatrixXd cov;
  int max_checked = 0;
  for (const testing::ExampleStep& s : testing::StreamByPose(p)) {
    ASSERT_TRUE(isam->Update(s.factors, s.values).status.ok());
    const int newest = static_cast<int>(isam->linearization_point().size()) - 1;
    ASSERT_TRUE(marginals.Marginal(newest, &cov).ok());
    int depth = 0;
    for (int x = isam->tree().CliqueOf(newest); x != BayesTree::kNone; x = isam->tree().clique(x).parent()) ++depth;
    EXPECT_EQ(marginals.stats().cliques_checked, depth);
    max_checked = std::max(max_checked, marginals.stats().cliques_checked);
  }
  EXPECT_LE(max_checked, 2);  // the newest pose is frontal in the root (constrained ordering)
  const DenseReference ref = Dense(*isam);
  const int newest = static_cast<int>(ref.dims.size()) - 1;
  const int one[] = {newest};
  EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9));
}

TEST(MarginalsTest, InvalidateForcesRecomputationOfTheSubtree) {
  auto isam = Solve(testing::MakePlanarProblem(30, 4, 41));
  const BayesTree& tree = isam->tree();
  BayesTreeMarginals marginals(&tree);
  marginals.ComputeAll();
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, 0);
  EXPECT_EQ(marginals.stats().cliques_checked, tree.NumCliques());
  // The recomputed root is bit-identical, so its children keep their joints.
  const int root[] = {tree.roots()[0]};
  marginals.Invalidate(root);
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, 1);
  EXPECT_EQ(marginals.stats().cliques_reused, static_cast<int>(tree.clique(root[0]).children().size()));
  marginals.InvalidateAll();
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, tree.NumCliques());
}

// ComputeAll() on an empty cache keeps only Σ_FF per clique (a full joint only for roots); the
// values must equal the dense inverse, and later queries must upgrade what they need.
TEST(MarginalsTest, FreshComputeAllKeepsTheBlockDiagonalAndQueriesUpgradeIt) {
  for (int kind = 0; kind < 2; ++kind) {
    auto isam = Solve(kind == 0 ? testing::MakePlanarProblem(40, 8, 81) : testing::MakeSpatialProblem(30, 82));
    const BayesTree& tree = isam->tree();
    const DenseReference ref = Dense(*isam);
    const int n = static_cast<int>(ref.dims.size());
    BayesTreeMarginals marginals(&tree);
    marginals.ComputeAll();
    EXPECT_EQ(marginals.stats().cliques_computed, tree.NumCliques());
    Eigen::MatrixXd cov;
    int frontal_only = 0;
    for (int c : tree.TopDownOrder()) {
      const Clique& cl = tree.clique(c);
      const auto J = marginals.CliqueJoint(c);
      if (cl.SeparatorDim() > 0 && J.rows() == cl.FrontalDim()) ++frontal_only;
      EXPECT_TRUE(J.rows() == cl.FrontalDim() || J.rows() == cl.FrontalDim() + cl.SeparatorDim());
    }
    EXPECT_GT(frontal_only, 0) << "the fresh pass kept full joints: nothing tested";
    for (int v = 0; v < n; ++v) {
      ASSERT_TRUE(marginals.CachedMarginal(v, &cov).ok());
      const int one[] = {v};
      EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "variable " << v;
    }
    // A deep variable: its path is recomputed as full joints, reproducing the same values, so
    // a ComputeAll() right after has nothing to do.
    int depth_max = 0;
    const int deepest = DeepestVariable(tree, n, &depth_max);
    ASSERT_GT(depth_max, 2);
    ASSERT_TRUE(marginals.Marginal(deepest, &cov).ok());
    EXPECT_EQ(marginals.stats().cliques_computed, depth_max - 1);  // all but the root
    const int c = tree.CliqueOf(deepest);
    EXPECT_EQ(marginals.CliqueJoint(c).rows(), tree.clique(c).FrontalDim() + tree.clique(c).SeparatorDim());
    marginals.ComputeAll();
    EXPECT_EQ(marginals.stats().cliques_computed, 0);
    // The full joint of a clique (fast path of JointMarginal) after the fresh pass.
    std::vector<int> s(tree.clique(c).separator().begin(), tree.clique(c).separator().end());
    s.push_back(deepest);
    ASSERT_TRUE(marginals.JointMarginal(s, &cov).ok());
    EXPECT_TRUE(RelativelyNear(cov, ref.Joint(s), 1e-9));
  }
}

// A clique recomputed under a parent that holds only Σ_FF: the parent (and its Σ_FF-only
// ancestors) are recomputed as full joints first; nothing else is.
TEST(MarginalsTest, RecomputingBelowAFrontalOnlyParentUpgradesOnlyThePath) {
  auto isam = Solve(testing::MakePlanarProblem(40, 8, 91));
  const BayesTree& tree = isam->tree();
  const DenseReference ref = Dense(*isam);
  BayesTreeMarginals marginals(&tree);
  marginals.ComputeAll();  // fresh: Σ_FF only
  int leaf = BayesTree::kNone, depth = 0;
  for (int c : tree.TopDownOrder()) {
    int d = 0;
    for (int x = c; x != BayesTree::kNone; x = tree.clique(x).parent()) ++d;
    if (tree.clique(c).children().empty() && d > depth) {
      leaf = c;
      depth = d;
    }
  }
  ASSERT_GT(depth, 2);
  const int one_clique[] = {leaf};
  marginals.Invalidate(one_clique);
  marginals.ComputeAll();
  EXPECT_EQ(marginals.stats().cliques_computed, depth - 1);  // the leaf and its ancestors but the root
  Eigen::MatrixXd cov;
  for (int v = 0; v < static_cast<int>(ref.dims.size()); ++v) {
    ASSERT_TRUE(marginals.CachedMarginal(v, &cov).ok());
    const int one[] = {v};
    EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "variable " << v;
  }
}

// Fresh passes again after InvalidateAll (the Σ_FF arena is replaced while full joints from
// queries exist), with the tree growing between calls; cached results stay exact.
TEST(MarginalsTest, FreshPassesAfterInvalidateAllAndAGrowingTree) {
  const ExampleProblem p = testing::MakeSpatialProblem(24, 95);
  auto isam = MakeIsam2();
  BayesTreeMarginals marginals(&isam->tree());
  const std::vector<testing::ExampleStep> steps = testing::StreamByPose(p);
  Eigen::MatrixXd cov;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    ASSERT_TRUE(isam->Update(steps[i].factors, steps[i].values).status.ok());
    if (i % 4 == 0) marginals.InvalidateAll();
    marginals.ComputeAll();
    if (i % 4 == 0) {
      EXPECT_EQ(marginals.stats().cliques_computed, isam->tree().NumCliques());
    }
    const int n = static_cast<int>(isam->linearization_point().size());
    ASSERT_TRUE(marginals.Marginal(n / 2, &cov).ok());  // leaves some full joints behind
    if (i % 5 == 0 || i + 1 == steps.size()) {
      const DenseReference ref = Dense(*isam);
      for (int v = 0; v < n; ++v) {
        ASSERT_TRUE(marginals.CachedMarginal(v, &cov).ok()) << "step " << i << " variable " << v;
        const int one[] = {v};
        ASSERT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9)) << "step " << i << " variable " << v;
      }
    }
  }
}

// Σ = (RᵀR)⁻¹ assembled densely from the tree's own conditionals (an independent reference for
// a tree edited by hand); dims and offsets as in `layout`.
DenseReference DenseFromTree(const BayesTree& tree, const DenseReference& layout) {
  DenseReference ref = layout;
  const int n = ref.offsets.back();
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(n, n);
  std::vector<int> global;  // clique column -> row/column of R
  for (int c : tree.TopDownOrder()) {
    const Clique& cl = tree.clique(c);
    global.clear();
    for (int k = 0; k < cl.num_frontals(); ++k) {
      for (int t = 0; t < cl.frontal_dim(k); ++t) global.push_back(ref.offsets[cl.frontal(k)] + t);
    }
    for (int k = 0; k < cl.num_separator(); ++k) {
      for (int t = 0; t < cl.separator_dim(k); ++t) global.push_back(ref.offsets[cl.separator()[k]] + t);
    }
    const auto rs = cl.conditional();
    for (int i = 0; i < cl.FrontalDim(); ++i) {
      for (int j = 0; j < static_cast<int>(global.size()); ++j) R(global[i], global[j]) = rs(i, j);
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(R.transpose() * R);
  EXPECT_EQ(llt.info(), Eigen::Success);
  ref.sigma = llt.solve(Eigen::MatrixXd::Identity(n, n));
  return ref;
}

// A clique re-defined with the same structure (ResetForElimination, then new numbers written, as
// elimination does) has the same ids, dims and parent as before: only its generation stamp tells
// the cache that its joint and its subtree's are stale. Both after a fresh pass (Σ_FF-only
// entries) and with full joints everywhere.
TEST(MarginalsTest, ACliqueRedefinedWithTheSameStructureIsNotServedFromTheCache) {
  auto isam = Solve(testing::MakePlanarProblem(40, 8, 101));
  const DenseReference before = Dense(*isam);
  const int n = static_cast<int>(before.dims.size());
  for (int full = 0; full < 2; ++full) {
    BayesTree tree = isam->tree();  // a copy to edit (it keeps the stamps)
    BayesTreeMarginals marginals(&tree);
    marginals.ComputeAll();
    Eigen::MatrixXd cov;
    if (full) {
      for (int v = 0; v < n; ++v) ASSERT_TRUE(marginals.Marginal(v, &cov).ok());
    }
    // A clique with a parent and children, so that the change must reach a subtree.
    int c = BayesTree::kNone;
    for (int x : tree.TopDownOrder()) {
      if (tree.clique(x).parent() != BayesTree::kNone && !tree.clique(x).children().empty()) c = x;
    }
    ASSERT_NE(c, BayesTree::kNone);
    int subtree = 0, depth = 0;
    for (int x : tree.TopDownOrder()) subtree += IsAncestorOrSelf(tree, c, x);
    for (int x = c; x != BayesTree::kNone; x = tree.clique(x).parent()) ++depth;
    ASSERT_GT(subtree, 1);

    Clique& cl = tree.mutable_clique(c);
    const std::vector<int> frontals(cl.frontals().begin(), cl.frontals().end());
    const std::vector<int> separator(cl.separator().begin(), cl.separator().end());
    std::vector<int> frontal_dims, separator_dims;
    for (int k = 0; k < cl.num_frontals(); ++k) frontal_dims.push_back(cl.frontal_dim(k));
    for (int k = 0; k < cl.num_separator(); ++k) separator_dims.push_back(cl.separator_dim(k));
    const Eigen::MatrixXd saved = cl.conditional();
    cl.ResetForElimination(frontals, frontal_dims, separator, separator_dims);
    auto rsd = cl.mutable_conditional();
    rsd = saved;
    rsd.leftCols(cl.FrontalDim()) *= 2.0;  // R doubled: still triangular with a positive diagonal
    const DenseReference after = DenseFromTree(tree, before);
    const int v0 = frontals[0], one0[] = {v0};
    ASSERT_FALSE(RelativelyNear(after.Joint(one0), before.Joint(one0), 1e-3)) << "the edit changed nothing";

    marginals.ComputeAll();
    EXPECT_GE(marginals.stats().cliques_computed, subtree);
    // The subtree, plus (after a fresh pass) the path above it upgraded to full joints.
    EXPECT_LE(marginals.stats().cliques_computed, subtree + (full ? 0 : depth - 1)) << "full " << full;
    for (int v = 0; v < n; ++v) {
      const int one[] = {v};
      ASSERT_TRUE(marginals.CachedMarginal(v, &cov).ok());
      EXPECT_TRUE(RelativelyNear(cov, after.Joint(one), 1e-9)) << "full " << full << " variable " << v;
      ASSERT_TRUE(marginals.Marginal(v, &cov).ok());
      EXPECT_TRUE(RelativelyNear(cov, after.Joint(one), 1e-9)) << "full " << full << " variable " << v;
    }
  }
}

// A fresh pass large enough for several threads (MarginalsParams::threads): the top on the
// calling thread, then the subtrees in parallel, each clique computed from the same inputs as on
// one thread. The marginals must be the same bit for bit, and the cache must behave afterwards as
// after a one-thread fresh pass. The tree: a SLAM-like system (6-dim poses, odometry, loop
// closures up to 40 poses back) eliminated in COLAMD order, which branches (iSAM2's constrained
// order on the small examples above gives trees too small or too chain-like to split).
TEST(MarginalsTest, ParallelFreshPassEqualsOneThreadBitForBit) {
  std::mt19937 rng(131);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int n = 1200;
  const std::vector<int> dims(n, 6);
  std::vector<JacobianFactor> jacobians;
  FactorIncidence incidence;
  const auto add = [&](std::vector<int> vars) {  // a random 6-row factor
    std::vector<Eigen::MatrixXd> blocks;
    for (std::size_t k = 0; k < vars.size(); ++k) blocks.push_back(Eigen::MatrixXd::NullaryExpr(6, 6, [&] { return n01(rng); }));
    const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(6, [&] { return n01(rng); });
    Result<JacobianFactor> f = JacobianFactor::Create(vars, blocks, b);
    ASSERT_TRUE(f.ok()) << f.status().ToString();
    jacobians.push_back(std::move(f).value());
    incidence.AddFactor(vars);
  };
  add({0});
  for (int i = 1; i < n; ++i) {
    add({i - 1, i});
    if (i % 3 == 0 && i > 40) add({i - 10 - static_cast<int>(rng() % 30), i});
  }
  Result<std::vector<int>> order = ColamdOrdering(n, incidence);
  ASSERT_TRUE(order.ok());
  std::vector<const JacobianFactor*> factors;
  for (const JacobianFactor& f : jacobians) factors.push_back(&f);
  BayesTree tree;
  EliminationResult eliminated;
  ASSERT_TRUE(Eliminate({.var_dims = dims, .factors = factors, .ordering = *order}, &tree, &eliminated).ok());

  BayesTreeMarginals one(&tree, {.threads = 1});
  one.ComputeAll();
  ASSERT_EQ(one.stats().threads_used, 1);
  std::vector<Eigen::MatrixXd> expected(n);
  for (int v = 0; v < n; ++v) ASSERT_TRUE(one.CachedMarginal(v, &expected[v]).ok());
  // One thread's against an independent computation (JointMarginal of variables in different
  // cliques solves with the conditionals; it does not use the cache).
  for (int v = 0; v + 1 < n; v += 97) {
    const int pair[] = {v, n - 1 - v};
    if (tree.CliqueOf(pair[0]) == tree.CliqueOf(pair[1])) continue;
    Eigen::MatrixXd joint;
    ASSERT_TRUE(one.JointMarginal(pair, &joint).ok());
    EXPECT_TRUE(RelativelyNear(expected[v], joint.topLeftCorner(6, 6), 1e-9)) << "variable " << v;
  }
  int depth = 0;
  const int deepest = DeepestVariable(tree, n, &depth);
  ASSERT_GT(depth, 2);
  for (int threads : {2, 3}) {
    BayesTreeMarginals many(&tree, {.threads = threads});
    many.ComputeAll();
    const int used = many.stats().threads_used;
    ASSERT_GE(used, 2) << "too small for the parallel path";
    ASSERT_LE(used, threads);
    EXPECT_GT(many.stats().top_cliques, 0);
    EXPECT_EQ(many.stats().cliques_computed, tree.NumCliques());
    Eigen::MatrixXd cov;
    for (int v = 0; v < n; ++v) {
      ASSERT_TRUE(many.CachedMarginal(v, &cov).ok());
      ASSERT_EQ(cov.rows(), expected[v].rows());
      ASSERT_TRUE((cov.array() == expected[v].array()).all())
          << "threads " << threads << " variable " << v << "\n" << cov << "\nvs\n" << expected[v];
    }
    // Afterwards as after one thread: Σ_FF-only entries below the roots, upgraded by a query.
    ASSERT_TRUE(many.Marginal(deepest, &cov).ok());
    EXPECT_EQ(many.stats().cliques_computed, depth - 1);
    EXPECT_TRUE((cov.array() == expected[deepest].array()).all());
    many.ComputeAll();
    EXPECT_EQ(many.stats().cliques_computed, 0);
    EXPECT_EQ(many.stats().threads_used, 1);
    many.InvalidateAll();  // a second fresh pass, reusing the threads' scratch
    many.ComputeAll();
    EXPECT_EQ(many.stats().threads_used, used);
    for (int v = 0; v < n; ++v) {
      ASSERT_TRUE(many.CachedMarginal(v, &cov).ok());
      ASSERT_TRUE((cov.array() == expected[v].array()).all()) << "again: threads " << threads << " variable " << v;
    }
  }
}

TEST(MarginalsTest, ParamsAreValidated) {
  EXPECT_TRUE(MarginalsParams{}.Validate().ok());
  const Status bad = MarginalsParams{.threads = 0}.Validate();
  EXPECT_EQ(bad.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bad.message().find("MarginalsParams::threads"), std::string::npos) << bad.message();
  auto isam = Solve(testing::MakePlanarProblem(10, 2, 121));
  EXPECT_DEATH(BayesTreeMarginals(&isam->tree(), {.threads = 0}), "MarginalsParams::threads");
}

TEST(MarginalsTest, BadQueriesReturnErrors) {
  auto isam = Solve(testing::MakePlanarProblem(10, 2, 51));
  BayesTreeMarginals marginals(&isam->tree());
  Eigen::MatrixXd cov;
  EXPECT_EQ(marginals.Marginal(1000, &cov).code(), StatusCode::kNotFound);
  EXPECT_EQ(marginals.Marginal(-1, &cov).code(), StatusCode::kNotFound);
  const int unknown[] = {0, 1000};
  EXPECT_EQ(marginals.JointMarginal(unknown, &cov).code(), StatusCode::kNotFound);
  const int twice[] = {3, 1, 3};
  EXPECT_EQ(marginals.JointMarginal(twice, &cov).code(), StatusCode::kInvalidArgument);
  Isam2Marginals by_key(isam.get());
  EXPECT_EQ(by_key.Marginal(MakeKey('q', 0), Isam2Marginals::Frame::kEstimate, &cov).code(),
            StatusCode::kNotFound);
}

// J = ∂ Local(E, θ ⊕ (δ + ε)) / ∂ε at 0, by central differences of the charts themselves.
Eigen::MatrixXd NumericalEstimateJacobian(const Variable& theta, const Eigen::VectorXd& delta) {
  Variable estimate = theta;
  RetractInPlace(&estimate, delta.data());
  return testing::NumericalJacobian(
      [&](const Eigen::VectorXd& eps) {
        Variable moved = theta;
        const Eigen::VectorXd d = delta + eps;
        RetractInPlace(&moved, d.data());
        return LocalCoordinates(estimate, moved);
      },
      Eigen::VectorXd::Zero(delta.size()));
}

TEST(MarginalsTest, EstimateTangentJacobianMatchesNumericalDifferentiationOfTheChart) {
  std::mt19937 rng(61);
  std::normal_distribution<double> n01(0.0, 1.0);
  for (int t = 0; t < 20; ++t) {
    const double scale = t < 10 ? 0.05 : 0.8;  // small (typical δ) and large updates
    std::vector<Variable> thetas = {
        Pose2(n01(rng), n01(rng), 3.0 * n01(rng)),
        Pose3(Rot3::FromRollPitchYaw(n01(rng), n01(rng), n01(rng)), Point3(n01(rng), n01(rng), n01(rng))),
        Point2(n01(rng), n01(rng)), Point3(n01(rng), n01(rng), n01(rng))};
    for (const Variable& theta : thetas) {
      const int d = TangentDim(TypeOf(theta));
      Eigen::VectorXd delta(d);
      for (int k = 0; k < d; ++k) delta[k] = scale * n01(rng);
      const Eigen::MatrixXd J = EstimateTangentJacobian(TypeOf(theta), delta.data());
      const Eigen::MatrixXd expected = NumericalEstimateJacobian(theta, delta);
      EXPECT_LT((J - expected).cwiseAbs().maxCoeff(), 1e-7) << VariableTypeName(TypeOf(theta)) << "\n"
                                                             << J << "\nvs\n" << expected;
    }
  }
}

TEST(MarginalsTest, Isam2MarginalsConvertToTheEstimateTangent) {
  for (int kind = 0; kind < 2; ++kind) {
    const ExampleProblem p = kind == 0 ? testing::MakePlanarProblem(20, 4, 71) : testing::MakeSpatialProblem(16, 72);
    auto isam = MakeIsam2();
    // Relinearise rarely so that δ ≠ 0 at the end.
    for (const testing::ExampleStep& s : testing::StreamByPose(p)) ASSERT_TRUE(isam->Update(s.factors, s.values).status.ok());
    const Values& theta = isam->linearization_point();
    const Values estimate = isam->CalculateEstimate();
    const DenseReference ref = Dense(*isam);
    Isam2Marginals marginals(isam.get());
    marginals.ComputeAll();
    Eigen::MatrixXd cov;
    for (int v = 0; v < static_cast<int>(theta.size()); ++v) {
      const Key key = theta.KeyAt(v);
      const int one[] = {v};
      ASSERT_TRUE(marginals.Marginal(key, Isam2Marginals::Frame::kLinearizationPoint, &cov).ok());
      EXPECT_TRUE(RelativelyNear(cov, ref.Joint(one), 1e-9));
      ASSERT_TRUE(marginals.Marginal(key, Isam2Marginals::Frame::kEstimate, &cov).ok());
      const Eigen::MatrixXd J = NumericalEstimateJacobian(theta.VariableAt(v), LocalCoordinates(theta.VariableAt(v), estimate.VariableAt(v)));
      EXPECT_TRUE(RelativelyNear(cov, J * ref.Joint(one) * J.transpose(), 1e-6));
    }
    // A joint at the estimate: blockdiag(J) Σ blockdiag(J)ᵀ.
    const int n = static_cast<int>(theta.size());
    const int vars[] = {n - 1, 0, n / 2};
    const Key keys[] = {theta.KeyAt(n - 1), theta.KeyAt(0), theta.KeyAt(n / 2)};
    ASSERT_TRUE(marginals.JointMarginal(keys, Isam2Marginals::Frame::kEstimate, &cov).ok());
    int total = 0;
    for (int v : vars) total += ref.dims[v];
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(total, total);
    int o = 0;
    for (int v : vars) {
      const Eigen::VectorXd delta = LocalCoordinates(theta.VariableAt(v), estimate.VariableAt(v));
      D.block(o, o, ref.dims[v], ref.dims[v]) = EstimateTangentJacobian(TypeOf(theta.VariableAt(v)), delta.data());
      o += ref.dims[v];
    }
    EXPECT_TRUE(RelativelyNear(cov, D * ref.Joint(vars) * D.transpose(), 1e-9));
  }
}

}  // namespace
}  // namespace slamd::core
