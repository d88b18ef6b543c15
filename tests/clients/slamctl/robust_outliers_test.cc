// Outlier loop closures on `slamctl sim` Manhattan worlds: with a robust kernel on the loop
// closures the absolute trajectory error (ATE) at 10% and 30% outliers stays within 1.5x of the
// outlier-free run's; without one the 30% world is far worse (so the test can fail).
//
// Protocol: one robot, 800 poses, fixed seeds; the initial guess is the odometry composition (a
// poor guess: metres of drift). Batch: Levenberg-Marquardt (core/batch) from that guess, the first
// pose anchored. Isam2: the `slamctl bench --solver isam2` protocol (one update per pose, each new
// pose predicted from its predecessor's estimate) followed by settling rounds. The ATE table is
// printed (run the binary to see it).
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>
#include <utility>

#include "clients/slamctl/robustify.h"
#include "clients/slamctl/sim_world.h"
#include "clients/slamctl/trajectory_error.h"
#include "core/batch/batch_solver.h"
#include "core/io/dataset_stream.h"
#include "core/isam/isam2.h"

namespace slamd::clients {
namespace {

using core::RobustKernel;

constexpr int kSteps = 800;
constexpr std::uint64_t kSeed = 7;
constexpr double kAnchorSigma = 1e-3;

struct World {
  core::Dataset data;
  core::Values truth;
};

const World& GetWorld(double outliers) {
  static std::map<double, World> cache;
  auto it = cache.find(outliers);
  if (it != cache.end()) return it->second;
  core::Result<sim::SimWorld> w = sim::Generate(
      sim::SimParams{.world = sim::WorldKind::kManhattan, .seed = kSeed, .steps = kSteps, .outliers = outliers});
  SLAMD_CHECK(w.ok()) << w.status().ToString();
  World world{sim::RobotDataset(*w, 0), sim::RobotTruth(*w, 0)};
  return cache.emplace(outliers, std::move(world)).first->second;
}

double Ate(const core::Values& estimate, const core::Values& truth) {
  const core::Result<TrajectoryError> ate = AbsoluteTrajectoryError(estimate, truth);
  SLAMD_CHECK(ate.ok()) << ate.status().ToString();
  return ate->rmse;
}

double BatchAte(double outliers, const RobustKernel& kernel) {
  const World& w = GetWorld(outliers);
  core::FactorGraph graph = RobustifyLoopClosures(w.data.graph, kernel);
  SLAMD_CHECK(core::AddGaugePrior(w.data.initial, w.data.poses.front(), kAnchorSigma, &graph).ok());
  const core::BatchResult r = core::Optimize(graph, w.data.initial);
  SLAMD_CHECK(r.status.ok()) << r.status.ToString();
  return Ate(r.values, w.truth);
}

double Isam2Ate(double outliers, const RobustKernel& kernel) {
  const World& w = GetWorld(outliers);
  core::Dataset data = w.data;
  data.graph = RobustifyLoopClosures(data.graph, kernel);
  std::unique_ptr<core::Isam2> isam = std::move(core::Isam2::Create()).value();
  const std::vector<core::DatasetStep> steps = core::MakeIncrementalSteps(data);
  for (const core::DatasetStep& step : steps) {
    core::FactorGraph factors;
    core::Values values;
    core::PrepareStep(step, [&](core::Key key) { return isam->CalculateEstimate(key); }, &factors, &values);
    if (&step == &steps.front()) SLAMD_CHECK(core::AddGaugePrior(values, step.pose, kAnchorSigma, &factors).ok());
    const core::Isam2Result r = isam->Update(factors, values);
    SLAMD_CHECK(r.status.ok()) << r.status.ToString();
  }
  const core::Isam2::RefineResult settled = isam->Refine(1e9, 20);  // rounds, not time: deterministic
  SLAMD_CHECK(settled.status.ok()) << settled.status.ToString();
  return Ate(isam->CalculateEstimate(), w.truth);
}

RobustKernel Kernel(const char* spec) { return *ParseRobustSpec(spec); }

// Every (outlier fraction, kernel, solver) ATE once, printed as a table, then the assertions.
TEST(RobustOutliersTest, RobustKernelsKeepTheAteWithinOneAndAHalfOfTheOutlierFreeRun) {
  const double fractions[] = {0.0, 0.1, 0.3};
  const char* kernels[] = {"none", "huber", "cauchy", "dcs", "gemanmcclure"};  // default parameters
  std::map<std::pair<double, std::string>, std::pair<double, double>> ate;     // -> (batch, isam2)
  std::printf("ATE rmse [m], Manhattan %d poses, seed %llu, odometry initial guess\n", kSteps,
              static_cast<unsigned long long>(kSeed));
  std::printf("%-8s %-18s %10s %10s\n", "outliers", "kernel", "batch LM", "isam2");
  for (double f : fractions) {
    for (const char* k : kernels) {
      const double b = BatchAte(f, Kernel(k)), i = Isam2Ate(f, Kernel(k));
      ate[{f, k}] = {b, i};
      std::printf("%-8.2f %-18s %10.4f %10.4f\n", f, RobustSpecString(Kernel(k)).c_str(), b, i);
    }
  }
  const auto at = [&](double f, const char* k) { return ate.at(std::make_pair(f, std::string(k))); };
  // The reference: the outlier-free world without a kernel (the best any kernel can hope for).
  const auto [batch0, isam0] = at(0.0, "none");
  ASSERT_LT(batch0, 0.2) << "the outlier-free solve itself went wrong";
  ASSERT_LT(isam0, 0.2);
  for (const char* k : {"cauchy", "dcs", "gemanmcclure"}) {
    for (double f : {0.1, 0.3}) {
      const auto [b, i] = at(f, k);
      EXPECT_LE(b, 1.5 * batch0) << k << " batch at " << f << " outliers";
      EXPECT_LE(i, 1.5 * isam0) << k << " isam2 at " << f << " outliers";
    }
  }
  // Without a kernel the outliers wreck the map; Huber (a convex kernel: outliers keep a pull
  // that grows with their residual) is not enough either. This is what makes the test able to fail.
  for (double f : {0.1, 0.3}) {
    EXPECT_GT(at(f, "none").first, 10.0 * batch0) << f;
    EXPECT_GT(at(f, "none").second, 10.0 * isam0) << f;
  }
  EXPECT_GT(at(0.3, "huber").first, 1.5 * batch0);
  EXPECT_GT(at(0.3, "huber").second, 1.5 * isam0);
}

}  // namespace
}  // namespace slamd::clients
