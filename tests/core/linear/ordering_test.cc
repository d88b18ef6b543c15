#include "core/linear/ordering.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <set>
#include <tuple>
#include <vector>

namespace slamd::core {
namespace {

// Factors of a rows x cols grid: a prior on variable 0 and one between factor per grid edge.
FactorIncidence GridIncidence(int rows, int cols, const std::vector<int>& label) {
  FactorIncidence incidence;
  incidence.AddFactor({label[0]});
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int v = r * cols + c;
      if (c + 1 < cols) incidence.AddFactor({label[v], label[v + 1]});
      if (r + 1 < rows) incidence.AddFactor({label[v], label[v + cols]});
    }
  }
  return incidence;
}

// Independent reference: block-level nonzeros of the Cholesky factor of the graph's Hessian
// pattern for an elimination order, by symbolic elimination (the not-yet-eliminated neighbours
// of each eliminated variable become a clique; it is enough to pass them to the first of them).
long FactorBlockNonZeros(int num_vars, const FactorIncidence& incidence,
                         const std::vector<int>& order) {
  std::vector<int> pos(num_vars);
  for (int k = 0; k < num_vars; ++k) pos[order[k]] = k;
  std::vector<std::set<int>> later(num_vars);  // neighbours eliminated later, by position
  for (int f = 0; f < incidence.NumFactors(); ++f) {
    for (int i = incidence.offsets[f]; i < incidence.offsets[f + 1]; ++i) {
      for (int j = incidence.offsets[f]; j < incidence.offsets[f + 1]; ++j) {
        const int a = incidence.vars[i], b = incidence.vars[j];
        if (pos[a] < pos[b]) later[pos[a]].insert(pos[b]);
      }
    }
  }
  long nnz = num_vars;  // diagonal blocks
  for (int k = 0; k < num_vars; ++k) {
    nnz += static_cast<long>(later[k].size());
    if (later[k].empty()) continue;
    const int parent = *later[k].begin();
    for (int u : later[k]) {
      if (u != parent) later[parent].insert(u);
    }
  }
  return nnz;
}

FactorIncidence RandomIncidence(int num_vars, int num_factors, std::mt19937* rng) {
  FactorIncidence incidence;
  std::uniform_int_distribution<int> var(0, num_vars - 1), arity(1, 3);
  for (int f = 0; f < num_factors; ++f) {
    std::vector<int> vars;
    const int size = arity(*rng);
    while (static_cast<int>(vars.size()) < size) {
      const int v = var(*rng);
      if (std::find(vars.begin(), vars.end(), v) == vars.end()) vars.push_back(v);
    }
    incidence.AddFactor(vars);
  }
  return incidence;
}

TEST(OrderingTest, ColamdReturnsPermutationIncludingUntouchedVariables) {
  std::mt19937 rng(7);
  // Variables 40..49 are touched by no factor.
  FactorIncidence incidence = RandomIncidence(40, 80, &rng);
  const Result<std::vector<int>> order = ColamdOrdering(50, incidence);
  ASSERT_TRUE(order.ok()) << order.status().ToString();
  ASSERT_EQ(order->size(), 50u);
  EXPECT_TRUE(IsPermutation(*order));
}

TEST(OrderingTest, EmptyAndTrivialInputs) {
  FactorIncidence none;
  const auto empty = ColamdOrdering(0, none);
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
  const auto unconnected = ColamdOrdering(4, none);
  ASSERT_TRUE(unconnected.ok());
  EXPECT_TRUE(IsPermutation(*unconnected));
  EXPECT_EQ(unconnected->size(), 4u);
  const auto grouped = ConstrainedColamdOrdering(4, none, {3, 1, 2, 0});
  ASSERT_TRUE(grouped.ok());
  EXPECT_EQ(*grouped, (std::vector<int>{3, 1, 2, 0}));
}

TEST(OrderingTest, DuplicateVariablesInAFactorAreTolerated) {
  FactorIncidence incidence;
  incidence.AddFactor({0, 1, 0});
  incidence.AddFactor({1, 2});
  const auto order = ColamdOrdering(3, incidence);
  ASSERT_TRUE(order.ok()) << order.status().ToString();
  EXPECT_TRUE(IsPermutation(*order));
}

TEST(OrderingTest, RejectsMalformedIncidence) {
  FactorIncidence out_of_range;
  out_of_range.AddFactor({0, 5});
  EXPECT_EQ(ColamdOrdering(3, out_of_range).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ConstrainedColamdOrdering(3, out_of_range, {0, 0, 0}).status().code(),
            StatusCode::kInvalidArgument);

  FactorIncidence bad_offsets;
  bad_offsets.vars = {0, 1};
  bad_offsets.offsets = {0, 3};
  EXPECT_EQ(ColamdOrdering(3, bad_offsets).status().code(), StatusCode::kInvalidArgument);
  bad_offsets.offsets = {1, 2};
  EXPECT_EQ(ColamdOrdering(3, bad_offsets).status().code(), StatusCode::kInvalidArgument);

  FactorIncidence fine;
  fine.AddFactor({0, 1});
  EXPECT_EQ(ConstrainedColamdOrdering(3, fine, {0, 1}).status().code(),
            StatusCode::kInvalidArgument);  // wrong group size
  EXPECT_EQ(ColamdOrdering(-1, fine).status().code(), StatusCode::kInvalidArgument);
}

TEST(OrderingTest, ConstrainedGroupsAreRespected) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 30 + trial * 5;
    const FactorIncidence incidence = RandomIncidence(n, 3 * n, &rng);
    std::vector<int> group(n);
    // Arbitrary, sparse, even negative group numbers: only their relative order counts.
    std::uniform_int_distribution<int> pick(0, 3);
    const int values[4] = {-7, 0, 2, 100};
    for (int& g : group) g = values[pick(rng)];
    const auto order = ConstrainedColamdOrdering(n, incidence, group);
    ASSERT_TRUE(order.ok()) << order.status().ToString();
    ASSERT_TRUE(IsPermutation(*order));
    for (int k = 1; k < n; ++k) {
      EXPECT_LE(group[(*order)[k - 1]], group[(*order)[k]]) << "trial " << trial << " k " << k;
    }
  }
}

TEST(OrderingTest, NewestVariablesLastAsInIsam2) {
  // A chain 0-1-...-19; force 18 and 19 to the end.
  FactorIncidence incidence;
  incidence.AddFactor({0});
  for (int v = 0; v + 1 < 20; ++v) incidence.AddFactor({v, v + 1});
  std::vector<int> group(20, 0);
  group[18] = group[19] = 1;
  const auto order = ConstrainedColamdOrdering(20, incidence, group);
  ASSERT_TRUE(order.ok());
  const std::set<int> last_two = {(*order)[18], (*order)[19]};
  EXPECT_EQ(last_two, (std::set<int>{18, 19}));
}

// Bundle adjustment's shape: cameras 0..c-1 in a chain, points c..c+p-1 each seen by 2-5
// cameras, a prior on camera 0.
FactorIncidence BundleIncidence(int cameras, int points, std::mt19937* rng) {
  FactorIncidence incidence;
  incidence.AddFactor({0});
  for (int i = 0; i + 1 < cameras; ++i) incidence.AddFactor({i, i + 1});
  std::uniform_int_distribution<int> first(0, cameras - 1), views(2, 5);
  for (int j = 0; j < points; ++j) {
    const int a = first(*rng), k = views(*rng);
    for (int v = 0; v < k; ++v) incidence.AddFactor({(a + 3 * v) % cameras, cameras + j});
  }
  return incidence;
}

// The points first, then the cameras with their groups; as little fill as CCOLAMD with the
// points in the first group (the Schur complement's fill is the same whatever the points'
// order); a factor on two points is refused.
TEST(OrderingTest, IndependentFirstEliminatesThePointsFirst) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const int cameras = 10 + 3 * trial, points = 20 * cameras, n = cameras + points;
    const FactorIncidence incidence = BundleIncidence(cameras, points, &rng);
    std::vector<char> independent(n, 0);
    std::vector<int> group(n, 0);
    for (int v = cameras; v < n; ++v) independent[v] = 1;
    group[cameras - 1] = group[cameras / 2] = 1;  // the newest, forced last
    const auto order = IndependentFirstOrdering(n, incidence, independent, group);
    ASSERT_TRUE(order.ok()) << order.status().ToString();
    ASSERT_TRUE(IsPermutation(*order));
    for (int k = 0; k < n; ++k) EXPECT_EQ(independent[(*order)[k]], k < points) << k;
    const std::set<int> last_two = {(*order)[n - 2], (*order)[n - 1]};
    EXPECT_EQ(last_two, (std::set<int>{cameras - 1, cameras / 2}));

    std::vector<int> points_first(n, 1);
    for (int v = cameras; v < n; ++v) points_first[v] = 0;
    points_first[cameras - 1] = points_first[cameras / 2] = 2;
    const auto reference = ConstrainedColamdOrdering(n, incidence, points_first);
    ASSERT_TRUE(reference.ok());
    EXPECT_LE(FactorBlockNonZeros(n, incidence, *order),
              FactorBlockNonZeros(n, incidence, *reference) * 21 / 20)
        << "trial " << trial;
  }
  FactorIncidence two_points;
  two_points.AddFactor({0, 1});
  two_points.AddFactor({1, 2});
  const auto refused = IndependentFirstOrdering(3, two_points, {0, 1, 1}, {0, 0, 0});
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(IndependentFirstOrdering(3, two_points, {0, 1}, {0, 0, 0}).status().code(),
            StatusCode::kInvalidArgument);
  // A point with no factor, a camera with none: still a permutation, the point first.
  const auto loose = IndependentFirstOrdering(4, two_points, {0, 0, 0, 1}, {0, 0, 0, 0});
  ASSERT_TRUE(loose.ok());
  EXPECT_EQ(loose->front(), 3);
  EXPECT_TRUE(IsPermutation(*loose));
}

// The points first only where the cameras they leave are densely tied: every pair of 6
// cameras shares a point (density 1), against a trajectory of 60 whose points are seen by two
// neighbours (density 1/30).
TEST(OrderingTest, IndependentFirstRefusesWhatItLeavesSparse) {
  const auto points_between = [](int cameras, const std::vector<std::pair<int, int>>& pairs) {
    FactorIncidence incidence;
    incidence.AddFactor({0});
    for (int j = 0; j < static_cast<int>(pairs.size()); ++j) {
      incidence.AddFactor({pairs[j].first, cameras + j});
      incidence.AddFactor({pairs[j].second, cameras + j});
    }
    return incidence;
  };
  std::vector<std::pair<int, int>> all_pairs, neighbours;
  for (int a = 0; a < 6; ++a) {
    for (int b = a + 1; b < 6; ++b) all_pairs.emplace_back(a, b);
  }
  for (int a = 0; a + 1 < 60; ++a) neighbours.emplace_back(a, a + 1);
  for (const auto& [cameras, pairs, dense] :
       {std::tuple{6, all_pairs, true}, std::tuple{60, neighbours, false}}) {
    const int n = cameras + static_cast<int>(pairs.size());
    std::vector<char> points(n, 0);
    for (int v = cameras; v < n; ++v) points[v] = 1;
    const FactorIncidence incidence = points_between(cameras, pairs);
    const std::vector<int> group(n, 0);
    const auto order = IndependentFirstOrdering(n, incidence, points, group, 0.5);
    EXPECT_EQ(order.ok(), dense) << cameras << " cameras";
    if (!dense) {
      EXPECT_EQ(order.status().code(), StatusCode::kFailedPrecondition);
      EXPECT_TRUE(IndependentFirstOrdering(n, incidence, points, group).ok());  // no minimum
    }
  }
}

TEST(OrderingTest, ColamdBeatsNaturalOrderOnGrids) {
  const int rows = 30, cols = 30, n = rows * cols;
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  std::vector<int> shuffled = identity;
  std::mt19937 rng(3);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  for (const auto& label : {identity, shuffled}) {
    const FactorIncidence incidence = GridIncidence(rows, cols, label);
    const auto order = ColamdOrdering(n, incidence);
    ASSERT_TRUE(order.ok());
    const long natural_fill = FactorBlockNonZeros(n, incidence, identity);
    const long colamd_fill = FactorBlockNonZeros(n, incidence, *order);
    EXPECT_LT(colamd_fill, natural_fill);
    // Row-major order of a w x w grid gives about n * w; minimum degree is far below.
    EXPECT_LT(colamd_fill, 0.6 * rows * n) << "natural " << natural_fill;
  }
}

TEST(OrderingTest, ConstrainedWithOneGroupMatchesQualityOfColamd) {
  const int rows = 20, cols = 20, n = rows * cols;
  std::vector<int> identity(n);
  std::iota(identity.begin(), identity.end(), 0);
  const FactorIncidence incidence = GridIncidence(rows, cols, identity);
  const auto plain = ColamdOrdering(n, incidence);
  const auto constrained = ConstrainedColamdOrdering(n, incidence, std::vector<int>(n, 5));
  ASSERT_TRUE(plain.ok() && constrained.ok());
  const long a = FactorBlockNonZeros(n, incidence, *plain);
  const long b = FactorBlockNonZeros(n, incidence, *constrained);
  EXPECT_LT(b, 1.5 * a);
  EXPECT_LT(b, FactorBlockNonZeros(n, incidence, identity));
}

TEST(OrderingTest, InversePermutation) {
  const std::vector<int> perm = {2, 0, 3, 1};
  const std::vector<int> inverse = InversePermutation(perm);
  EXPECT_EQ(inverse, (std::vector<int>{1, 3, 0, 2}));
  for (int k = 0; k < 4; ++k) EXPECT_EQ(inverse[perm[k]], k);
  EXPECT_TRUE(IsPermutation(perm));
  EXPECT_FALSE(IsPermutation({0, 0, 1}));
  EXPECT_FALSE(IsPermutation({0, 3, 1}));
  EXPECT_FALSE(IsPermutation({-1, 0}));
}

}  // namespace
}  // namespace slamd::core
