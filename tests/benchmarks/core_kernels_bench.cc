// Micro-benchmarks of the kernels behind Isam2's slowest steps (Google Benchmark; not a test:
// run by hand, figures in BENCHMARKS.md):
//   build/tests/core_kernels_bench [--benchmark_filter=REGEX]
// ReEliminateAll/<dataset> relinearises and re-eliminates a whole development dataset
// (Isam2UpdateOptions::force_full, 1 thread), as the largest relinearisation steps do (on a
// pose graph or, ReEliminateAllBal, a bundle adjustment's graph of cameras and points); the
// counters are the medians of its phases (ms). PartialCholesky/n/k: the dense clique kernel's
// rate (GFLOPs counter); BlasDgemm/n: the BLAS's matrix product, the machine's practical peak.
#include <benchmark/benchmark.h>

// C linkage declared here, as in core/linear/partial_cholesky.cc (ATLAS's cblas.h has no guard).
extern "C" {
#include <cblas.h>
}

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "core/ba/reconstruction_stream.h"
#include "core/base/memory_usage.h"
#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/io/dataset.h"
#include "core/io/sfm_io.h"
#include "core/isam/isam2.h"
#include "core/linear/partial_cholesky.h"

namespace slamd::core {
namespace {

void BM_LinearizeBetweenPose3(benchmark::State& state) {
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
  const Eigen::MatrixXd covariance = a * a.transpose() + Eigen::MatrixXd::Identity(6, 6);
  Eigen::Matrix<double, 6, 1> xi1, xi2;
  xi1 << 0.1, 0.2, 0.3, 0.1, -0.2, 0.3;
  xi2 << 1, 2, -1, 0.3, 0.2, -0.1;
  const BetweenFactor<Pose3> factor(1, 2, Pose3::Exp(xi1),
                                    NoiseModel::FromCovariance(covariance).value());
  Values values;
  if (!values.Insert(1, Variable(Pose3::Exp(xi2))).ok() ||
      !values.Insert(2, Variable(Pose3::Exp(xi1 + xi2))).ok()) {
    state.SkipWithError("values");
    return;
  }
  LinearizedFactor linearized;
  for (auto _ : state) {
    factor.Linearize(values, &linearized);
    benchmark::DoNotOptimize(linearized);
  }
}
BENCHMARK(BM_LinearizeBetweenPose3);

// The dense kernel of clique elimination (core/linear/partial_cholesky.h): k of n columns of
// a symmetric positive-definite matrix eliminated in place, as a clique with k frontal and n - k
// separator (+ right-hand side) scalars is. Counter GFLOPs: Σ_{j<k} (n - j)² flops (each column
// updates the trailing lower triangle, a multiply and a subtraction per entry) per second.
void BM_PartialCholesky(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int k = static_cast<int>(state.range(1));
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  const Eigen::MatrixXd spd = a * a.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd m(n, n);
  std::vector<double> ref(n);
  double flops = 0.0;
  for (int j = 0; j < k; ++j) flops += static_cast<double>(n - j) * (n - j);
  for (auto _ : state) {
    state.PauseTiming();
    m = spd;
    std::fill(ref.begin(), ref.end(), 1.0);
    state.ResumeTiming();
    if (internal::PartialCholeskyLower(m.data(), n, n, k, ref.data(), 0.0) >= 0) {
      state.SkipWithError("not positive definite");
      return;
    }
    benchmark::DoNotOptimize(m.data());
  }
  state.counters["GFLOPs"] =
      benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}
// Cliques as iSAM2 makes them: a few poses over a separator (k = n / 2), and the root of a dense
// 3D graph (k = n).
BENCHMARK(BM_PartialCholesky)
    ->Args({48, 24})
    ->Args({96, 12})
    ->Args({128, 64})
    ->Args({256, 128})
    ->Args({512, 256})
    ->Args({512, 512})
    ->Args({1024, 1024})
    ->Unit(benchmark::kMicrosecond);

// The machine's practical peak for the kernels above: the BLAS's matrix product C = A B (n x n,
// 2 n³ flops; OpenBLAS picks AVX2/AVX-512 kernels at run time), which PartialCholesky's large
// sizes reach through dsyrk.
void BM_BlasDgemm(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, n);
  Eigen::MatrixXd c(n, n);
  for (auto _ : state) {
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, n, n, n, 1.0, a.data(), n, b.data(), n,
                0.0, c.data(), n);
    benchmark::DoNotOptimize(c.data());
  }
  state.counters["GFLOPs"] = benchmark::Counter(2e-9 * n * n * static_cast<double>(n),
                                                benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_BlasDgemm)->Arg(1024)->Arg(2048)->Unit(benchmark::kMicrosecond);

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

void TimeReEliminateAll(benchmark::State& state, const FactorGraph& graph, const Values& values,
                        const Isam2Params& params);

void BM_ReEliminateAll(benchmark::State& state, const std::string& file) {
  Result<Dataset> dataset = ReadDataset(std::string(SLAMD_SHARED_DATASETS) + "/" + file);
  if (!dataset.ok()) {
    state.SkipWithError(dataset.status().ToString().c_str());
    return;
  }
  FactorGraph graph = dataset->graph;
  const Key first = dataset->poses[0];
  if (dataset->is_3d) {
    graph.Add(std::make_shared<PriorFactor<Pose3>>(first, dataset->initial.At<Pose3>(first),
                                                   NoiseModel::Isotropic(6, 1e-3).value()));
  } else {
    graph.Add(std::make_shared<PriorFactor<Pose2>>(first, dataset->initial.At<Pose2>(first),
                                                   NoiseModel::Isotropic(3, 1e-3).value()));
  }
  TimeReEliminateAll(state, graph, dataset->initial, {.threads = 1});
}

// The same on a BAL reconstruction: every step of its camera-by-camera replay (calibrations
// refined) in one update, then the whole graph relinearised and re-eliminated, each update ending
// with the dog leg (Gauss-Newton alone diverges on it).
void BM_ReEliminateAllBal(benchmark::State& state, const std::string& file) {
  Result<Reconstruction> r = ReadReconstruction(std::string(SLAMD_SHARED_DATASETS) + "/" + file);
  Result<ReconstructionStream> stream =
      r.ok() ? ReconstructionStream::Create(*r) : Result<ReconstructionStream>(r.status());
  if (!stream.ok()) {
    state.SkipWithError(stream.status().ToString().c_str());
    return;
  }
  FactorGraph graph;
  Values values;
  for (int i = 0; i < stream->num_steps(); ++i) {
    const ReconstructionStep step = stream->Next();
    for (const FactorPtr& f : step.factors) graph.Add(f);
    for (int k = 0; k < static_cast<int>(step.values.size()); ++k) {
      (void)values.Insert(step.values.KeyAt(k), step.values.VariableAt(k));
    }
  }
  TimeReEliminateAll(state, graph, values, {.trust_region = {.enabled = true}, .threads = 1});
}

void TimeReEliminateAll(benchmark::State& state, const FactorGraph& graph, const Values& values,
                        const Isam2Params& params) {
  KeepFreedMemoryForReuse();  // as slamd and slamctl do
  std::unique_ptr<Isam2> isam = std::move(Isam2::Create(params).value());
  const Isam2Result first_update = isam->Update(graph, values, {});
  if (!first_update.status.ok()) {
    state.SkipWithError(first_update.status.ToString().c_str());
    return;
  }
  std::vector<double> relinearize, order, eliminate, solve;
  for (auto _ : state) {
    const Isam2Result r = isam->Update({}, {}, {.force_full = true});
    if (!r.status.ok()) {
      state.SkipWithError(r.status.ToString().c_str());
      return;
    }
    relinearize.push_back(1e3 * r.seconds.relinearize);
    order.push_back(1e3 * r.seconds.order);
    eliminate.push_back(1e3 * r.seconds.eliminate);
    solve.push_back(1e3 * r.seconds.solve);
  }
  state.counters["relinearize_ms"] = Median(relinearize);
  state.counters["order_ms"] = Median(order);
  state.counters["eliminate_ms"] = Median(eliminate);
  state.counters["solve_ms"] = Median(solve);
}
BENCHMARK_CAPTURE(BM_ReEliminateAll, parking_garage, std::string("parking-garage.g2o"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReEliminateAll, M3500, std::string("input_M3500_g2o.g2o"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_ReEliminateAllBal, ladybug_49, std::string("bal/problem-49-7776-pre.txt"))
    ->Unit(benchmark::kMillisecond)
    ->Iterations(10);  // more full Gauss-Newton steps and a point runs off (indeterminate)

}  // namespace
}  // namespace slamd::core

BENCHMARK_MAIN();
