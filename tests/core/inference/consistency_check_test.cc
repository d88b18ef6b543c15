#include "core/inference/consistency_check.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "tests/core/inference/random_linear_system.h"

namespace slamd::core {

// Reaches into the tree's links to build trees the public API cannot produce.
class BayesTreeTestPeer {
 public:
  static void SetParent(BayesTree* tree, int id, int parent) {
    tree->cliques_[id]->parent_ = parent;
  }
  static std::vector<int>& Children(BayesTree* tree, int id) {
    return tree->cliques_[id]->children_;
  }
  static std::vector<int>& Roots(BayesTree* tree) { return tree->roots_; }
};

namespace {

using testing::EliminateAll;
using testing::MakeRandomSystem;
using testing::RandomLinearSystem;

class ConsistencyCheckTest : public ::testing::Test {
 protected:
  void SetUp() override {
    system_ = MakeRandomSystem(20, 15, false, 17);
    auto order = ColamdOrdering(system_.NumVars(), system_.Incidence());
    ASSERT_TRUE(order.ok());
    ASSERT_NO_FATAL_FAILURE(EliminateAll(system_, order.value(), &tree_, &result_));
    ASSERT_TRUE(CheckConsistency(tree_).ok()) << CheckConsistency(tree_).ToString();
    // A clique with a parent and a non-empty separator, and its parent.
    for (int id : result_.cliques) {
      if (tree_.clique(id).parent() != BayesTree::kNone) child_ = id;
    }
    ASSERT_GE(child_, 0);
    parent_ = tree_.clique(child_).parent();
  }

  void ExpectBroken(const std::string& fragment) {
    const Status status = CheckConsistency(tree_);
    EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
    EXPECT_NE(status.message().find(fragment), std::string::npos) << status.message();
  }

  // Rebuilds the structure of clique `id` with a different separator (matrices zeroed, R's
  // diagonal set to 1 so only the structural error shows).
  void ResetClique(int id, std::vector<int> separator) {
    Clique& c = tree_.mutable_clique(id);
    const std::vector<int> frontals(c.frontals().begin(), c.frontals().end());
    std::vector<int> fdims, sdims;
    for (int v : frontals) fdims.push_back(system_.dims[v]);
    for (int v : separator) sdims.push_back(system_.dims[v]);
    c.Reset(frontals, fdims, separator, sdims);
    for (int i = 0; i < c.FrontalDim(); ++i) c.mutable_conditional()(i, i) = 1.0;
  }

  RandomLinearSystem system_;
  BayesTree tree_;
  EliminationResult result_;
  int child_ = -1;
  int parent_ = -1;
};

TEST_F(ConsistencyCheckTest, EmptyTreeIsConsistent) {
  EXPECT_TRUE(CheckConsistency(BayesTree()).ok());
}

TEST_F(ConsistencyCheckTest, DetachedOrphanBreaksRunningIntersection) {
  tree_.Detach(child_);
  ExpectBroken("non-empty separator");
}

TEST_F(ConsistencyCheckTest, WrongVariableMap) {
  const int v = tree_.clique(child_).frontal(0);
  tree_.SetCliqueOf(v, parent_);
  ExpectBroken("CliqueOf(" + std::to_string(v) + ")");
}

TEST_F(ConsistencyCheckTest, VariableFrontalTwice) {
  std::vector<int> frontals(tree_.clique(child_).frontals().begin(),
                            tree_.clique(child_).frontals().end());
  frontals.push_back(tree_.clique(parent_).frontal(0));
  Clique& c = tree_.mutable_clique(child_);
  std::vector<int> fdims, sdims;
  for (int v : frontals) fdims.push_back(system_.dims[v]);
  for (int v : c.separator()) sdims.push_back(system_.dims[v]);
  const std::vector<int> sep(c.separator().begin(), c.separator().end());
  c.Reset(frontals, fdims, sep, sdims);
  ExpectBroken("is frontal in both");
}

TEST_F(ConsistencyCheckTest, SeparatorNotInParent) {
  // A separator variable that is frontal somewhere but not in the parent's frontals/separator.
  const Clique& child = tree_.clique(child_);
  const Clique& parent = tree_.clique(parent_);
  int outsider = -1;
  for (int v = 0; v < system_.NumVars() && outsider < 0; ++v) {
    const auto& pf = parent.frontals();
    const auto& ps = parent.separator();
    const auto& cf = child.frontals();
    if (std::find(pf.begin(), pf.end(), v) == pf.end() &&
        std::find(ps.begin(), ps.end(), v) == ps.end() &&
        std::find(cf.begin(), cf.end(), v) == cf.end()) {
      outsider = v;
    }
  }
  ASSERT_GE(outsider, 0);
  std::vector<int> sep(child.separator().begin(), child.separator().end());
  sep.push_back(outsider);
  ResetClique(child_, sep);
  ExpectBroken("neither frontal nor separator in its parent");
}

TEST_F(ConsistencyCheckTest, FrontalAlsoInSeparator) {
  std::vector<int> sep(tree_.clique(child_).separator().begin(),
                       tree_.clique(child_).separator().end());
  sep.push_back(tree_.clique(child_).frontal(0));
  ResetClique(child_, sep);
  ExpectBroken("both frontal and separator");
}

TEST_F(ConsistencyCheckTest, ParentChildLinksDisagree) {
  BayesTreeTestPeer::Children(&tree_, parent_).clear();
  ExpectBroken("not listed exactly once among the children");
}

TEST_F(ConsistencyCheckTest, ChildDoesNotPointBack) {
  BayesTreeTestPeer::Children(&tree_, parent_).push_back(tree_.roots()[0]);
  ExpectBroken("does not point back");
}

TEST_F(ConsistencyCheckTest, CycleIsUnreachable) {
  // Make parent_ a child of child_ (and keep child_ under parent_): a 2-cycle cut off from the
  // roots.
  const int grandparent = tree_.clique(parent_).parent();
  if (grandparent != BayesTree::kNone) {
    auto& siblings = BayesTreeTestPeer::Children(&tree_, grandparent);
    siblings.erase(std::find(siblings.begin(), siblings.end(), parent_));
  } else {
    auto& roots = BayesTreeTestPeer::Roots(&tree_);
    roots.erase(std::find(roots.begin(), roots.end(), parent_));
  }
  BayesTreeTestPeer::SetParent(&tree_, parent_, child_);
  BayesTreeTestPeer::Children(&tree_, child_).push_back(parent_);
  ExpectBroken("reachable from the roots");
}

TEST_F(ConsistencyCheckTest, MatrixProblems) {
  // R must be upper-triangular with a positive diagonal, and finite.
  Clique& c = tree_.mutable_clique(tree_.roots()[0]);
  ASSERT_GE(c.FrontalDim(), 2);
  const double saved = c.mutable_conditional()(1, 0);
  c.mutable_conditional()(1, 0) = 0.5;
  ExpectBroken("not upper-triangular");
  c.mutable_conditional()(1, 0) = saved;
  c.mutable_conditional()(0, 0) = -1.0;
  ExpectBroken("non-positive diagonal");
  c.mutable_conditional()(0, 0) = 1.0;
  c.mutable_conditional()(0, c.FrontalDim()) = std::nan("");
  ExpectBroken("not finite");
}

TEST_F(ConsistencyCheckTest, DimensionMismatch) {
  // The child's separator claims a different dim for a variable than where it is frontal.
  Clique& c = tree_.mutable_clique(child_);
  const std::vector<int> frontals(c.frontals().begin(), c.frontals().end());
  const std::vector<int> sep(c.separator().begin(), c.separator().end());
  ASSERT_FALSE(sep.empty());
  std::vector<int> fdims, sdims;
  for (int v : frontals) fdims.push_back(system_.dims[v]);
  for (int v : sep) sdims.push_back(system_.dims[v]);
  sdims[0] += 1;
  c.Reset(frontals, fdims, sep, sdims);
  for (int i = 0; i < c.FrontalDim(); ++i) c.mutable_conditional()(i, i) = 1.0;
  ExpectBroken("where it is frontal");
}

}  // namespace
}  // namespace slamd::core
