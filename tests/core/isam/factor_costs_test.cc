// FactorCosts (core/isam/factor_costs.h): the sum of the factors' robust costs, bitwise the serial
// loop's with any number of threads, re-evaluating only the factors whose values changed.
#include "core/isam/factor_costs.h"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <random>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"

namespace slamd::core {
namespace {

// A prior on a Point2 that counts its evaluations (the helpers evaluate too: atomic).
class CountingPrior : public TypedFactor<CountingPrior, 2, Point2> {
  using Base = TypedFactor<CountingPrior, 2, Point2>;

 public:
  static const char* TypeName() { return "TestCountingPrior"; }
  CountingPrior(Key key, const Point2& at, std::atomic<int>* count)
      : Base({key}, NoiseModel::Isotropic(2, 0.5).value(), RobustKernel{}),
        at_(at),
        count_(count) {}
  void EncodeMeasured(std::vector<double>* out) const override {
    out->insert(out->end(), at_.data(), at_.data() + 2);
  }
  Base::ErrorVector Evaluate(const Point2& x, Base::JacobianAt<0>* H) const {
    count_->fetch_add(1);
    if (H) H->setIdentity();
    return x - at_;
  }

 private:
  Point2 at_;
  std::atomic<int>* count_;
};

double SerialSum(const Values& at, const std::vector<FactorPtr>& factors) {
  double sum = 0.0;
  for (const FactorPtr& f : factors) {
    if (f) sum += f->Cost(at);
  }
  return sum;
}

struct Problem {
  Values values;
  std::vector<FactorPtr> factors;
  std::vector<std::vector<int>> vars;  // per factor, its variables' slots
};

// A chain of poses with odometry (Huber on every third) and a prior on each: enough factors
// for the helpers to take chunks.
Problem RobustChain(int n) {
  Problem p;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int i = 0; i < n; ++i) {
    EXPECT_TRUE(
        p.values.Insert(MakeKey('x', i), Pose2(i + noise(rng), noise(rng), noise(rng))).ok());
  }
  const NoiseModel sigma = NoiseModel::Isotropic(3, 0.05).value();
  for (int i = 0; i < n; ++i) {
    p.factors.push_back(
        std::make_shared<PriorFactor<Pose2>>(MakeKey('x', i), Pose2(i, 0, 0), sigma));
    p.vars.push_back({i});
    if (i + 1 == n) break;
    const RobustKernel robust =
        i % 3 == 0 ? RobustKernel::Create(RobustKernel::Kind::kHuber, 1.345).value()
                   : RobustKernel{};
    p.factors.push_back(std::make_shared<BetweenFactor<Pose2>>(
        MakeKey('x', i), MakeKey('x', i + 1), Pose2(1.0, 0.0, 0.0), sigma, robust));
    p.vars.push_back({i, i + 1});
  }
  return p;
}

TEST(FactorCostsTest, SumIsTheSerialLoopsBitwiseWithAnyNumberOfThreads) {
  Problem p = RobustChain(3000);
  const auto vars = [&](int f) { return std::span<const int>(p.vars[f]); };
  const double serial = SerialSum(p.values, p.factors);
  for (int helpers : {0, 1, 3}) {
    WorkerPool pool(helpers);
    FactorCosts costs;
    EXPECT_EQ(costs.Sum(p.values, p.factors, vars, &pool), serial) << helpers << " helpers";
    // Again from the cache, and after moving every variable.
    EXPECT_EQ(costs.Sum(p.values, p.factors, vars, &pool), serial) << helpers << " helpers";
    Values moved = p.values;
    for (int v = 0; v < static_cast<int>(moved.size()); ++v) {
      const double d[3] = {0.01, -0.02, 0.003};
      RetractInPlace(&moved.MutableVariableAt(v), d);
    }
    EXPECT_EQ(costs.Sum(moved, p.factors, vars, &pool), SerialSum(moved, p.factors))
        << helpers << " helpers";
  }
}

TEST(FactorCostsTest, EvaluatesOnlyTheFactorsWhoseFactorOrValuesChanged) {
  std::atomic<int> count{0};
  Problem p;
  for (int i = 0; i < 50; ++i) {
    ASSERT_TRUE(p.values.Insert(MakeKey('l', i), Point2(i, 1.0)).ok());
    p.factors.push_back(std::make_shared<CountingPrior>(MakeKey('l', i), Point2(i, 0.0), &count));
    p.vars.push_back({i});
  }
  const auto vars = [&](int f) { return std::span<const int>(p.vars[f]); };
  WorkerPool pool(1);
  FactorCosts costs;
  const auto sum = [&](const Values& at) {
    count = 0;
    const double s = costs.Sum(at, p.factors, vars, &pool);
    const int evaluated = count.exchange(0);
    EXPECT_EQ(s, SerialSum(at, p.factors));
    return evaluated;
  };
  EXPECT_EQ(sum(p.values), 50);
  EXPECT_EQ(sum(p.values), 0);  // nothing changed
  Values moved = p.values;
  moved.MutableVariableAt(7) = Point2(7.0, 0.5);
  EXPECT_EQ(sum(moved), 1);
  EXPECT_EQ(sum(p.values), 1);  // back: variable 7 differs from the last call's again
  costs.Forget(3);
  EXPECT_EQ(sum(p.values), 1);
  // Another factor in a slot (without Forget) is evaluated; a null slot is left out of the sum.
  p.factors[5] = std::make_shared<CountingPrior>(MakeKey('l', 5), Point2(5.0, 2.0), &count);
  p.factors[9] = nullptr;
  EXPECT_EQ(sum(p.values), 1);
  // Slots that now hold other variables (renumbered) count as changed, even with the same bits.
  Values same_bits = p.values, swapped;
  same_bits.MutableVariableAt(20) = Point2(1.0, 1.0);
  same_bits.MutableVariableAt(21) = Point2(1.0, 1.0);
  EXPECT_EQ(sum(same_bits), 2);
  for (int v = 0; v < 50; ++v) {
    const int from = v == 20 ? 21 : (v == 21 ? 20 : v);
    ASSERT_TRUE(swapped.Insert(same_bits.KeyAt(from), same_bits.VariableAt(from)).ok());
  }
  std::swap(p.vars[20], p.vars[21]);
  EXPECT_EQ(sum(swapped), 2);
  costs.Clear();
  EXPECT_EQ(sum(swapped), 49);
}

}  // namespace
}  // namespace slamd::core
