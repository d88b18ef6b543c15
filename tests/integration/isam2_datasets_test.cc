// Isam2 on the development datasets, streamed as `slamctl bench --solver isam2` does: after
// every step the estimate equals the batch solution of the same graph linearised at the same
// point, the tree passes the structural check, and refinement settles on the batch optimum.
#include <gtest/gtest.h>

#include "core/batch/batch_solver.h"
#include "core/batch/normal_equations.h"
#include "core/inference/consistency_check.h"
#include "core/io/dataset_stream.h"
#include "core/isam/isam2.h"
#include "tests/testing/datasets.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

// Streams the first `limit` steps of a dataset; `check` runs after every update.
template <typename Check>
void StreamDataset(const Dataset& data, std::size_t limit, Isam2& isam, const Isam2UpdateOptions& options,
                   Check check) {
  const std::vector<DatasetStep> steps = MakeIncrementalSteps(data);
  for (std::size_t i = 0; i < std::min(limit, steps.size()); ++i) {
    FactorGraph factors;
    Values values;
    PrepareStep(steps[i], [&](Key k) { return isam.CalculateEstimate(k); }, &factors, &values);
    if (i == 0) {
      ASSERT_TRUE(AddGaugePrior(values, steps[i].pose, 1e-3, &factors).ok());
    }
    const Isam2Result r = isam.Update(factors, values, options);
    ASSERT_TRUE(r.status.ok()) << KeyToString(steps[i].pose) << ": " << r.status.ToString();
    check(i);
  }
}

struct ParityCase {
  const char* file;
  std::size_t steps;
};

class Isam2DatasetParityTest : public ::testing::TestWithParam<ParityCase> {};

TEST_P(Isam2DatasetParityTest, EveryStepMatchesBatchAtTheSameLinearizationPoint) {
  const std::string path = testing::SharedDatasetPath(GetParam().file);
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const Result<Dataset> data = ReadDataset(path);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  auto isam = std::move(Isam2::Create()).value();
  StreamDataset(*data, GetParam().steps, *isam, {.force_full_solve = true}, [&](std::size_t i) {
    const Status consistent = CheckConsistency(isam->tree());
    ASSERT_TRUE(consistent.ok()) << "step " << i << ": " << consistent.ToString();
    const Values expected = testing::BatchStepAt(isam->Factors(), isam->linearization_point());
    ASSERT_LT(testing::MaxDifference(isam->CalculateEstimate(), expected), 1e-6) << "step " << i;
  });
}

INSTANTIATE_TEST_SUITE_P(Datasets, Isam2DatasetParityTest,
                         ::testing::Values(ParityCase{"w100.graph", 100}, ParityCase{"manhattan.g2o", 300},
                                           ParityCase{"victoriaPark.txt", 300}),
                         [](const auto& info) { return std::to_string(info.index); });

class Isam2DatasetSettleTest : public ::testing::TestWithParam<const char*> {};

TEST_P(Isam2DatasetSettleTest, RefineSettlesOnTheBatchOptimum) {
  const std::string path = testing::SharedDatasetPath(GetParam());
  SLAMD_SKIP_IF_NO_SHARED_DATASET(path);
  const Result<Dataset> data = ReadDataset(path);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  auto isam = std::move(Isam2::Create()).value();
  StreamDataset(*data, data->poses.size(), *isam, {}, [&](std::size_t) {});
  const Isam2::RefineResult refined = isam->Refine(10.0);
  ASSERT_TRUE(refined.status.ok()) << refined.status.ToString();
  EXPECT_TRUE(refined.converged);
  EXPECT_TRUE(CheckConsistency(isam->tree()).ok());
  const FactorGraph graph = isam->Factors();
  const BatchResult batch = Optimize(graph, isam->CalculateEstimate(), {.relative_tolerance = 1e-10});
  ASSERT_TRUE(batch.status.ok());
  EXPECT_NEAR(isam->Chi2(), batch.summary.final_chi2, 1e-4 * batch.summary.final_chi2);
}

INSTANTIATE_TEST_SUITE_P(Datasets, Isam2DatasetSettleTest,
                         ::testing::Values("w100.graph", "intel.g2o", "input_M3500_g2o.g2o",
                                           "parking-garage.g2o"),
                         [](const auto& info) { return std::to_string(info.index); });

}  // namespace
}  // namespace slamd::core
