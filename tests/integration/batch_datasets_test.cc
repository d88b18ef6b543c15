// Every development dataset converges under the batch solver, to the chi2 recorded in
// BENCHMARKS.md (same options as `slamctl bench DATASET --solver batch --init INIT`).
#include <gtest/gtest.h>

#include "core/batch/batch_solver.h"
#include "core/batch/initialization.h"
#include "core/io/dataset.h"
#include "tests/testing/datasets.h"

namespace slamd::core {
namespace {

struct Case {
  const char* file;
  InitialGuess init;
  bool covariance_noise;
  double chi2;       // pinned final chi2 (BENCHMARKS.md)
  double reference;  // best known chi2 (0 when none): we must not be above it
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.file; }

class BatchDatasetsTest : public ::testing::TestWithParam<Case> {};

TEST_P(BatchDatasetsTest, ConvergesToThePinnedChi2) {
  const Case& c = GetParam();
  const std::string path = testing::SharedDatasetPath(c.file);
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  ReadOptions read;
  if (c.covariance_noise) read.isam_noise = ReadOptions::IsamNoise::kCovariance;
  const Result<Dataset> data = ReadDataset(path, read);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  FactorGraph graph = data->graph;
  ASSERT_TRUE(AddGaugePrior(data->initial, data->poses.front(), 1e-3, &graph).ok());
  const Result<Values> initial = MakeInitialGuess(c.init, data->graph, data->initial, data->poses);
  ASSERT_TRUE(initial.ok()) << initial.status().ToString();
  const BatchResult r = Optimize(graph, *initial);
  ASSERT_TRUE(r.status.ok()) << r.status.ToString();
  EXPECT_EQ(r.summary.termination, BatchTermination::kConverged);
  EXPECT_NEAR(r.summary.final_chi2, c.chi2, 1e-6 * c.chi2) << r.summary.Brief();
  if (c.reference > 0) {
    EXPECT_LE(r.summary.final_chi2, c.reference * (1 + 1e-6));
  }
}

INSTANTIATE_TEST_SUITE_P(
    Datasets, BatchDatasetsTest,
    ::testing::Values(Case{"input_M3500_g2o.g2o", InitialGuess::kAsGiven, false, 137.9129509, 137.927},
                      Case{"manhattan.g2o", InitialGuess::kAsGiven, false, 3549.036796, 3549.47},
                      Case{"intel.g2o", InitialGuess::kAsGiven, false, 45.00469582, 45.005},
                      Case{"input_INTEL_g2o.g2o", InitialGuess::kSpanningTree, false, 215.8302353, 215.854},
                      Case{"input_INTEL_g2o.g2o", InitialGuess::kLago, false, 215.8306305, 215.854},
                      Case{"parking-garage.g2o", InitialGuess::kAsGiven, false, 1.268384799, 1.268385},
                      Case{"victoriaPark.txt", InitialGuess::kIncremental, false, 6184.120626, 6184.2},
                      Case{"w100.graph", InitialGuess::kAsGiven, false, 1.17840859, 0}),
    [](const ::testing::TestParamInfo<Case>& info) {
      std::string name = std::string(info.param.file) + "_" + std::to_string(static_cast<int>(info.param.init));
      for (char& ch : name) if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return name;
    });

}  // namespace
}  // namespace slamd::core
