// The Chow-Liu tree of a node-removal summary (core/inference/chow_liu.h) against the dense
// summary: every variable's marginal covariance and mean the dense summary's, and far fewer
// couplings.
#include "core/inference/chow_liu.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>

#include "core/base/check.h"
#include "core/factors/linear_container_factor.h"
#include "core/factors/linearized_factor.h"
#include "core/inference/node_removal.h"
#include "tests/core/inference/dense_system.h"
#include "tests/testing/example_graphs.h"

namespace slamd::core {
namespace {

// The marginal covariance and mean of every variable (blocks at `column`, named by `keys`) under
// the dense summary's system and the tree's agree.
void ExpectSameMarginals(const Eigen::MatrixXd& dense_h, const Eigen::VectorXd& dense_g,
                         const Eigen::MatrixXd& tree_h, const Eigen::VectorXd& tree_g,
                         const std::vector<int>& column, const KeyVector& keys) {
  const Eigen::MatrixXd dense_cov = dense_h.inverse(), tree_cov = tree_h.inverse();
  const Eigen::VectorXd dense_mean = dense_h.ldlt().solve(-dense_g);
  const Eigen::VectorXd tree_mean = tree_h.ldlt().solve(-tree_g);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const int a = column[i], d = column[i + 1] - column[i];
    const Eigen::MatrixXd c = dense_cov.block(a, a, d, d);
    EXPECT_LT((tree_cov.block(a, a, d, d) - c).cwiseAbs().maxCoeff(),
              1e-6 * c.cwiseAbs().maxCoeff())
        << KeyToString(keys[i]);
    EXPECT_LT((tree_mean.segment(a, d) - dense_mean.segment(a, d)).cwiseAbs().maxCoeff(), 1e-6)
        << KeyToString(keys[i]);
  }
}

// The values of `keys` (planar poses and points) moved rigidly together, far.
Values RigidlyMoved(const Values& values, const KeyVector& keys) {
  const Pose2 motion(25.0, -10.0, 1.2);
  Values moved;
  for (Key key : keys) {
    const Variable& v = values.Get(key);
    const Status s = std::holds_alternative<Pose2>(v)
                         ? moved.Insert(key, motion * std::get<Pose2>(v))
                         : moved.Insert(key, motion.TransformFrom(std::get<Point2>(v)));
    SLAMD_CHECK(s.ok()) << s.ToString();
  }
  return moved;
}

// `s` (on `keys`) with `root` held, the gauge of a summary of relative measurements fixed: the
// rest of the system, its columns renumbered.
testing::DenseSystem Held(const testing::DenseSystem& s, const KeyVector& keys, Key root) {
  std::vector<int> keep;
  testing::DenseSystem out;
  out.column.push_back(0);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (keys[i] == root) continue;
    for (int c = s.column[i]; c < s.column[i + 1]; ++c) keep.push_back(c);
    out.column.push_back(static_cast<int>(keep.size()));
  }
  const int m = static_cast<int>(keep.size());
  out.H.resize(m, m);
  out.g.resize(m);
  for (int a = 0; a < m; ++a) {
    out.g(a) = s.g(keep[a]);
    for (int c = 0; c < m; ++c) out.H(a, c) = s.H(keep[a], keep[c]);
  }
  return out;
}

// The Kullback-Leibler divergence KL(p || q) of the Gaussians of two (held) systems, in nats.
double Divergence(const testing::DenseSystem& p, const testing::DenseSystem& q) {
  const auto log_det = [](const Eigen::MatrixXd& m) {
    const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(m).matrixL();
    return 2.0 * l.diagonal().array().log().sum();
  };
  const Eigen::VectorXd d = q.H.ldlt().solve(-q.g) - p.H.ldlt().solve(-p.g);
  return 0.5 * ((q.H * p.H.inverse()).trace() - static_cast<double>(p.H.rows()) + log_det(p.H) -
                log_det(q.H) + d.dot(q.H * d));
}

TEST(ChowLiuTest, TreeKeepsEveryMarginalOfTheDenseSummary) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 13);
  // x0 carries the prior: the summary determines every blanket variable (checked below).
  const KeyVector removed = {MakeKey('x', 0), MakeKey('x', 1)};
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu})
                            .value();
  ASSERT_GE(r.blanket.size(), 3u);
  ASSERT_EQ(r.summary.size(), r.blanket.size());
  int unary = 0;
  for (const FactorPtr& f : r.summary) {
    ASSERT_LE(f->keys().size(), 2u);
    unary += f->keys().size() == 1;
  }
  EXPECT_EQ(unary, 1);  // the root
  const testing::DenseSystem dense = testing::Dense({r.marginal}, p.initial, r.blanket);
  const testing::DenseSystem tree = testing::Dense(r.summary, p.initial, r.blanket);
  const std::vector<int>& at = dense.column;
  const Eigen::MatrixXd &dense_h = dense.H, &tree_h = tree.H;
  const Eigen::VectorXd &dense_g = dense.g, &tree_g = tree.g;
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(dense_h).eigenvalues().minCoeff(),
            1e-6 * dense_h.diagonal().maxCoeff());
  ExpectSameMarginals(dense_h, dense_g, tree_h, tree_g, at, r.blanket);
  // Sparser: the tree couples fewer pairs than the dense summary (all of them).
  int coupled = 0;
  for (std::size_t i = 0; i < r.blanket.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      coupled +=
          tree_h.block(at[i], at[j], at[i + 1] - at[i], at[j + 1] - at[j]).cwiseAbs().maxCoeff() >
          0.0;
    }
  }
  EXPECT_EQ(coupled, static_cast<int>(r.blanket.size()) - 1);
}

// Relative measurements only (no prior among the removed): the summary's information is
// singular along the global frame. The tree is made in one blanket variable's frame: each
// factor also touches that root, the tree adds nothing along the dense summary's null space, and
// with the root held (the gauge fixed the same way in both) every other variable's marginal
// covariance and mean are the dense summary's.
TEST(ChowLiuTest, SummaryOfRelativeMeasurementsIsShiftedToARoot) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 10);
  const KeyVector removed = {MakeKey('x', 3), MakeKey('x', 4), MakeKey('x', 5), MakeKey('x', 6)};
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu})
                            .value();
  const int k = static_cast<int>(r.blanket.size());
  ASSERT_GE(k, 5);
  ASSERT_EQ(static_cast<int>(r.summary.size()), k - 1);
  // The root: the one key every tree factor has.
  int root = -1, common = 0;
  for (int i = 0; i < k; ++i) {
    if (std::all_of(r.summary.begin(), r.summary.end(), [&](const FactorPtr& f) {
          return std::find(f->keys().begin(), f->keys().end(), r.blanket[i]) != f->keys().end();
        })) {
      root = i;
      ++common;
    }
  }
  ASSERT_EQ(common, 1);
  // In the root-relative form: a rigid motion of the whole blanket leaves every factor's error as
  // it was (where the dense summary, in world coordinates, resists it).
  const Values moved = RigidlyMoved(p.initial, r.blanket);
  for (const FactorPtr& f : r.summary) {
    ASSERT_TRUE(static_cast<const LinearContainerFactor&>(*f).root_relative());
    EXPECT_LT((f->Error(moved) - f->Error(p.initial)).norm(), 1e-9);
  }
  EXPECT_GT(std::abs(r.marginal->Chi2(moved) - r.marginal->Chi2(p.initial)), 1.0);
  for (const FactorPtr& f : r.summary) EXPECT_LE(f->keys().size(), 3u);
  const testing::DenseSystem dense = testing::Dense({r.marginal}, p.initial, r.blanket);
  const testing::DenseSystem tree = testing::Dense(r.summary, p.initial, r.blanket);
  const std::vector<int>& at = dense.column;
  const int n = at.back();
  // The gauge: the dense summary's null space, 3-dimensional (a planar frame), which the tree
  // leaves empty.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(dense.H);
  const double top = eigen.eigenvalues()(n - 1);
  ASSERT_LT(eigen.eigenvalues()(2), 1e-10 * top);
  ASSERT_GT(eigen.eigenvalues()(3), 1e-6 * top);
  const Eigen::MatrixXd null = eigen.eigenvectors().leftCols(3);
  EXPECT_LT((tree.H * null).cwiseAbs().maxCoeff(), 1e-8 * top);
  EXPECT_LT((tree.g.transpose() * null).cwiseAbs().maxCoeff(), 1e-8 * dense.g.norm() + 1e-12);
  // The root held: the rest of both systems.
  KeyVector others = r.blanket;
  others.erase(others.begin() + root);
  const testing::DenseSystem dense_rest = Held(dense, r.blanket, r.blanket[root]);
  const testing::DenseSystem tree_rest = Held(tree, r.blanket, r.blanket[root]);
  ExpectSameMarginals(dense_rest.H, dense_rest.g, tree_rest.H, tree_rest.g, dense_rest.column,
                      others);
}

// TreeEdgeFrame::kParent on a summary of relative measurements that is a chain (odometry alone,
// every other pose removed): each conditional either carries the child along with its parent
// or says nothing of it, so the factors on two keys drop nothing: the tree's system is the
// dense summary's, gauge and all. No factor holds three keys.
TEST(ChowLiuTest, EdgesInTheParentFrameAreExactOnAChain) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 0, 11);
  std::vector<FactorPtr> odometry;
  for (const FactorPtr& f : p.graph.factors()) {
    const std::span<const Key> k = f->keys();
    if (k.size() == 2 && KeyIndex(k[1]) == KeyIndex(k[0]) + 1) odometry.push_back(f);
  }
  const KeyVector removed = {MakeKey('x', 3), MakeKey('x', 5), MakeKey('x', 7)};
  const NodeRemoval r = MarginalizeOut(odometry, p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu,
                                        .edge_frame = TreeEdgeFrame::kParent})
                            .value();
  ASSERT_EQ(r.blanket.size(), 4u);
  ASSERT_EQ(r.summary.size(), 3u);
  for (const FactorPtr& f : r.summary) {
    EXPECT_TRUE(static_cast<const LinearContainerFactor&>(*f).root_relative());
    EXPECT_EQ(f->keys().size(), 2u);
  }
  const testing::DenseSystem dense = testing::Dense({r.marginal}, p.initial, r.blanket);
  const testing::DenseSystem tree = testing::Dense(r.summary, p.initial, r.blanket);
  EXPECT_LT((tree.H - dense.H).cwiseAbs().maxCoeff(), 1e-6 * dense.H.cwiseAbs().maxCoeff());
  EXPECT_LT((tree.g - dense.g).cwiseAbs().maxCoeff(), 1e-6 * (1.0 + dense.g.cwiseAbs().maxCoeff()));
}

// A corridor: poses 1 m apart with odometry, each seeing the landmarks within 2.5 m (two rows,
// 1.5 m apart along it); no loop closure. The summary of a stretch of poses between two kept
// ones is then mostly local links, as a window's are.
::slamd::testing::ExampleProblem Corridor(int num_poses, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  ::slamd::testing::ExampleProblem p;
  const NoiseModel odo = *NoiseModel::Diagonal(Vector3(0.05, 0.05, 0.02));
  const NoiseModel obs = *NoiseModel::Isotropic(2, 0.1);
  for (int i = 0; i < num_poses; ++i) {
    const Pose2 x(i, 0.1 * std::sin(0.3 * i), 0.03 * std::cos(0.3 * i));
    (void)p.truth.Insert(MakeKey('x', i), x);
    (void)p.initial.Insert(MakeKey('x', i),
                           x.Compose(Pose2(0.1 * n01(rng), 0.1 * n01(rng), 0.02 * n01(rng))));
    if (i == 0) continue;
    const Key a = MakeKey('x', i - 1), b = MakeKey('x', i);
    const Pose2 z = p.truth.At<Pose2>(a).Between(x).Compose(
        Pose2(0.05 * n01(rng), 0.05 * n01(rng), 0.02 * n01(rng)));
    p.graph.Emplace<BetweenFactor<Pose2>>(a, b, z, odo);
  }
  for (int j = 0; 1.5 * (j / 2) < num_poses; ++j) {
    const Point2 l(1.5 * (j / 2), j % 2 ? 2.0 : -2.0);
    const Key lk = MakeKey('l', j);
    (void)p.truth.Insert(lk, l);
    (void)p.initial.Insert(lk, Point2(l + Point2(0.1 * n01(rng), 0.1 * n01(rng))));
    for (int i = 0; i < num_poses; ++i) {
      const Pose2& x = p.truth.At<Pose2>(MakeKey('x', i));
      if ((x.translation() - l).norm() > 2.5) continue;
      const Point2 z = x.TransformTo(l) + Point2(0.1 * n01(rng), 0.1 * n01(rng));
      p.graph.Emplace<RelativePointFactor<Pose2, Point2>>(MakeKey('x', i), lk, z, obs);
    }
  }
  return p;
}

// TreeEdgeFrame::kParent where the summary is no chain (a corridor's odd poses removed over 16
// m, the even ones kept as a window keeps keyframes): fewer factors hold the root than in the
// root's frame (there, all), each stays blind to a rigid motion of the whole blanket, and every
// variable's marginal variance with the root held stays near the dense summary's (7.6 % off at
// most here).
TEST(ChowLiuTest, EdgesInTheParentFrameLeaveTheRootOutOfSome) {
  const ::slamd::testing::ExampleProblem p = Corridor(40, 3);
  KeyVector removed;
  for (int i = 11; i < 26; i += 2) removed.push_back(MakeKey('x', i));
  const NodeRemoval in_root = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                             {.form = NodeRemovalParams::Form::kChowLiu})
                                  .value();
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu,
                                        .edge_frame = TreeEdgeFrame::kParent})
                            .value();
  const Key root = in_root.summary.front()->keys().back();
  const auto holding_root = [&](const NodeRemoval& n) {
    return std::count_if(n.summary.begin(), n.summary.end(), [&](const FactorPtr& f) {
      return std::count(f->keys().begin(), f->keys().end(), root) > 0;
    });
  };
  ASSERT_EQ(r.summary.size(), in_root.summary.size());
  EXPECT_EQ(holding_root(in_root), static_cast<long>(in_root.summary.size()));
  EXPECT_LT(holding_root(r), static_cast<long>(r.summary.size()));
  const Values moved = RigidlyMoved(p.initial, r.blanket);
  for (const FactorPtr& f : r.summary) {
    ASSERT_TRUE(static_cast<const LinearContainerFactor&>(*f).root_relative());
    EXPECT_LE(f->keys().size(), 3u);
    EXPECT_LT((f->Error(moved) - f->Error(p.initial)).norm(), 1e-9);
  }
  const auto held_cov = [&](const std::vector<FactorPtr>& factors) {
    return Eigen::MatrixXd(
        Held(testing::Dense(factors, p.initial, r.blanket), r.blanket, root).H.inverse());
  };
  const Eigen::MatrixXd dense_cov = held_cov({r.marginal}), tree_cov = held_cov(r.summary);
  double worst = 0.0;
  for (int c = 0; c < dense_cov.rows(); ++c) {
    worst = std::max(worst, std::abs(tree_cov(c, c) / dense_cov(c, c) - 1.0));
  }
  EXPECT_LT(worst, 0.1);
}

// The caller's preference decides the root among the poses that can take the gauge.
TEST(ChowLiuTest, PreferredPoseIsTheRoot) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 10);
  const KeyVector removed = {MakeKey('x', 3), MakeKey('x', 4), MakeKey('x', 5), MakeKey('x', 6)};
  const KeyVector blanket = MarginalizeOut(p.graph.factors(), p.initial, removed).value().blanket;
  int roots = 0;
  for (Key want : blanket) {
    if (KeySymbol(want) != 'x') continue;
    const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                         {.form = NodeRemovalParams::Form::kChowLiu,
                                          .prefer_root = [&](Key k) { return k == want; }})
                              .value();
    for (const FactorPtr& f : r.summary) EXPECT_EQ(f->keys().back(), want);
    ++roots;
  }
  EXPECT_GE(roots, 2);
}

// A landmark removed with the poses: a pose that saw it elsewhere gets a range and bearing from
// the summary and nothing else, so the summary is singular beyond the gauge. The tree is still
// finite and shifted to a root, and adds next to nothing along the summary's null space.
TEST(ChowLiuTest, NullDirectionsBeyondTheGaugeGetANegligiblePrior) {
  const ::slamd::testing::ExampleProblem p = ::slamd::testing::MakePlanarProblem(20, 4, 14);
  const KeyVector removed = {MakeKey('x', 7), MakeKey('x', 8), MakeKey('l', 1)};
  const NodeRemoval r = MarginalizeOut(p.graph.factors(), p.initial, removed,
                                       {.form = NodeRemovalParams::Form::kChowLiu})
                            .value();
  const int k = static_cast<int>(r.blanket.size());
  ASSERT_EQ(static_cast<int>(r.summary.size()), k - 1);
  const testing::DenseSystem dense = testing::Dense({r.marginal}, p.initial, r.blanket);
  const testing::DenseSystem tree = testing::Dense(r.summary, p.initial, r.blanket);
  const int n = dense.column.back();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(dense.H);
  const double top = eigen.eigenvalues()(n - 1);
  int nullity = 0;
  while (eigen.eigenvalues()(nullity) < 1e-10 * top) ++nullity;
  ASSERT_GT(nullity, 3);
  ASSERT_TRUE(tree.H.allFinite() && tree.g.allFinite());
  const Eigen::MatrixXd null = eigen.eigenvectors().leftCols(nullity);
  EXPECT_LT((null.transpose() * tree.H * null).norm(), 1e-7 * top);
  // Elsewhere it is no weaker than the summary: about as much information in total.
  EXPECT_GT(tree.H.trace(), 0.5 * dense.H.trace());
}

// Two parents per variable (a second one where it tells most beyond the tree parent): closer to
// the dense summary than the tree, in either edge frame, with every factor on three blanket
// variables at most (plus the root it is relative to), and still blind to a rigid motion of the
// whole blanket.
TEST(ChowLiuTest, SecondParentsBringTheSummaryCloser) {
  const ::slamd::testing::ExampleProblem p = Corridor(40, 3);
  KeyVector removed;
  for (int i = 11; i < 26; i += 2) removed.push_back(MakeKey('x', i));
  const auto summary = [&](TreeEdgeFrame frame, int parents) {
    return MarginalizeOut(p.graph.factors(), p.initial, removed,
                          {.form = NodeRemovalParams::Form::kChowLiu,
                           .edge_frame = frame,
                           .tree_parents = parents})
        .value();
  };
  const Values moved = RigidlyMoved(p.initial, summary(TreeEdgeFrame::kRoot, 1).blanket);
  for (TreeEdgeFrame frame : {TreeEdgeFrame::kRoot, TreeEdgeFrame::kParent}) {
    const NodeRemoval tree = summary(frame, 1), two = summary(frame, 2);
    const Key root = tree.summary.front()->keys().back();
    ASSERT_EQ(two.summary.front()->keys().back(), root);
    ASSERT_EQ(two.blanket, tree.blanket);
    const auto held = [&](const std::vector<FactorPtr>& factors) {
      return Held(testing::Dense(factors, p.initial, two.blanket), two.blanket, root);
    };
    const testing::DenseSystem dense = held({two.marginal});
    const double tree_kl = Divergence(dense, held(tree.summary));
    const double two_kl = Divergence(dense, held(two.summary));
    EXPECT_GT(tree_kl, 0.1);
    EXPECT_LT(two_kl, 0.5 * tree_kl);
    int three = 0;
    for (const FactorPtr& f : two.summary) {
      EXPECT_LE(f->keys().size(), 4u);
      three += f->keys().size() == 4u || (f->keys().size() == 3u && frame == TreeEdgeFrame::kRoot);
      EXPECT_LT((f->Error(moved) - f->Error(p.initial)).norm(), 1e-9);
    }
    EXPECT_GT(three, 0);
  }
}

}  // namespace
}  // namespace slamd::core
