// Regression tests for what the fuzz targets found: every file in tests/fuzz/regressions/<target>/
// is a (minimised) crashing input, run through the same function as the libFuzzer target
// (fuzz_util.h), in every build (no clang needed). A test fails by crashing, as the fuzzer did.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/isam/isam2.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::fuzz {
namespace {

using Target = void (*)(const std::uint8_t*, std::size_t);

TEST(FuzzRegressionsTest, EverySavedInputRunsCleanly) {
  const std::map<std::string, Target> targets = {{"config", FuzzConfig},
                                                 {"dataset", FuzzDataset},
                                                 {"inbound", FuzzInbound},
                                                 {"journal", FuzzJournal},
                                                 {"state", FuzzState}};
  const std::filesystem::path root = SLAMD_FUZZ_REGRESSIONS_DIR;
  int inputs = 0;
  for (const auto& dir : std::filesystem::directory_iterator(root)) {
    const auto target = targets.find(dir.path().filename().string());
    ASSERT_NE(target, targets.end()) << "no fuzz target for " << dir.path();
    for (const auto& file : std::filesystem::directory_iterator(dir.path())) {
      SCOPED_TRACE(file.path().string());
      std::ifstream in(file.path(), std::ios::binary);
      const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                    std::istreambuf_iterator<char>());
      target->second(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      ++inputs;
    }
  }
  EXPECT_GE(inputs, 1);
}

// The core of regressions/inbound/isam2_rollback_factor_not_linearised: a landmark 8e283 m away
// made a new factor whose linearisation is not finite; Isam2::AddFactors returned before adding
// it to the variable index, and Rollback then aborted removing it from there
// (isam2_steps.cc, "factor 10 is not on variable 5"). Now the update fails cleanly and the
// solver is left as it was.
TEST(FuzzRegressionsTest, Isam2UpdateWithAFactorThatDoesNotLineariseRollsBack) {
  using core::BetweenFactor;
  using core::FactorGraph;
  using core::MakeKey;
  using core::NoiseModel;
  using core::Pose2;
  using core::PriorFactor;
  using core::Values;
  auto isam = core::Isam2::Create({}).value();
  const core::Key x0 = MakeKey('x', 0), x1 = MakeKey('x', 1), x2 = MakeKey('x', 2);
  FactorGraph first;
  first.Emplace<PriorFactor<Pose2>>(x0, Pose2(), NoiseModel::Unit(3));
  Values v0;
  ASSERT_TRUE(v0.Insert(x0, Pose2()).ok());
  ASSERT_TRUE(isam->Update(first, v0).status.ok());

  // Whitened error ~ 1e300 / 1e-200: not finite.
  FactorGraph bad;
  bad.Emplace<BetweenFactor<Pose2>>(x0, x1, Pose2(), NoiseModel::Isotropic(3, 1e-200).value());
  Values v1;
  ASSERT_TRUE(v1.Insert(x1, Pose2(1e300, 0, 0)).ok());
  EXPECT_FALSE(isam->Update(bad, v1).status.ok());
  EXPECT_EQ(isam->Factors().size(), 1u);

  // The solver still works: a good update after the failed one.
  FactorGraph good;
  good.Emplace<BetweenFactor<Pose2>>(x0, x2, Pose2(1, 0, 0), NoiseModel::Unit(3));
  Values v2;
  ASSERT_TRUE(v2.Insert(x2, Pose2(1, 0, 0)).ok());
  ASSERT_TRUE(isam->Update(good, v2).status.ok());
  EXPECT_NEAR(std::get<Pose2>(isam->CalculateEstimate(x2)).x(), 1.0, 1e-9);
}

}  // namespace
}  // namespace slamd::fuzz
