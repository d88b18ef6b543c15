// Runs the slamctl binary: `slamctl bench` on a small dataset, and its argument errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/clients/slamctl/slamctl_runner.h"
#include "tests/testing/datasets.h"
#include "tests/testing/files.h"

namespace slamd::clients {
namespace {

using testing::RunSlamctl;
using testing::SlamctlRun;

TEST(BenchTest, JsonHasTheDocumentedFields) {
  const SlamctlRun r = RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* field :
       {"\"dataset\"", "\"poses\"", "\"landmarks\"", "\"factors\"", "\"solver\": \"batch\"",
        "\"iterations\"", "\"initial_chi2\"", "\"final_chi2\"", "\"total_s\"", "\"peak_rss_mb\"",
        "\"termination\": \"converged\""}) {
    EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
  }
  EXPECT_EQ(r.out.front(), '{');
  // The default start is chosen among those tried.
  EXPECT_NE(r.out.find("\"init\": \"auto:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"init_tried\": [{\"init\": \"file\""), std::string::npos) << r.out;
}

// A number field of the JSON object printed by `slamctl bench --json`: the first `"name": `
// at or after `from`.
double JsonNumber(const std::string& json, const std::string& name, std::size_t from = 0) {
  const std::size_t at = json.find("\"" + name + "\": ", from);
  EXPECT_NE(at, std::string::npos) << name << " missing from " << json;
  return at == std::string::npos ? -1.0 : std::stod(json.substr(at + name.size() + 4));
}

// On a simulated world with loop closures, so that steps add different numbers of factors.
TEST(BenchTest, Isam2JsonHasStepPercentilesAndSettles) {
  const std::string dir = ::testing::TempDir() + "slamd_bench_steps_" + std::to_string(getpid());
  ASSERT_EQ(RunSlamctl("sim manhattan --steps 300 -o " + dir).exit_code, 0);
  const std::string csv = dir + "/steps.csv";
  const SlamctlRun r = RunSlamctl(
      "bench " + dir + "/world.g2o" +
      " --solver isam2 --json --compare-batch --settle 1 --rate 20000 --step-times " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* field :
       {"\"solver\": \"isam2\"", "\"step_ms\": {\"p50\"", "\"p90\"", "\"p99\"", "\"max\"",
        "\"step_ms_per_factor\": {\"p50\"", "\"final_chi2\"", "\"chi2_before_settle\"",
        "\"batch_chi2\"", "\"relinearized_total\"", "\"peak_rss_mb\"", "\"heap_peak_mb\""}) {
    EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
  }
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header,
            "step,pose,factors,ms,relinearized,reeliminated,add_ms,relinearize_ms,remove_top_ms,"
            "order_ms,eliminate_ms,solve_ms");
  int lines = 0;
  std::vector<double> per_step, per_factor;  // step times, once per step and once per factor
  std::vector<std::size_t> step_factors;
  for (std::string line; std::getline(in, line);) {
    ++lines;
    // The update's phases are part of the step (which also reads the newest estimate).
    std::vector<double> ms;
    std::istringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) {
      if (ms.size() != 1)
        ms.push_back(std::stod(field));
      else
        ms.push_back(0.0);  // the pose name
    }
    ASSERT_EQ(ms.size(), 12u) << line;
    double phases = 0.0;
    for (int i = 6; i < 12; ++i) {
      EXPECT_GE(ms[i], 0.0) << line;
      phases += ms[i];
    }
    EXPECT_LE(phases, ms[3] + 1e-3) << line;  // 1e-3 ms: the CSV's rounding
    EXPECT_GE(ms[2], 1.0) << line;            // every step adds a factor
    per_step.push_back(ms[3]);
    step_factors.push_back(static_cast<std::size_t>(ms[2]));
    per_factor.insert(per_factor.end(), step_factors.back(), ms[3]);
  }
  EXPECT_GT(lines, 1);
  // The dataset's factors and the first pose's anchor.
  EXPECT_EQ(static_cast<double>(per_factor.size()), JsonNumber(r.out, "factors") + 1);
  // Percentiles by rank (the nearest of q (n - 1)), from the CSV: steps with loop closures
  // weigh more once per factor.
  const auto rank = [](std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
  };
  const std::size_t steps_at = r.out.find("\"step_ms\": ");
  const std::size_t per_factor_at = r.out.find("\"step_ms_per_factor\": ");
  bool weighted_differs = false;  // else this run could not tell the two apart
  for (const auto& [q, name] : {std::pair{0.5, "p50"}, {0.9, "p90"}, {0.99, "p99"}, {1.0, "max"}}) {
    EXPECT_NEAR(JsonNumber(r.out, name, steps_at), rank(per_step, q), 1e-5) << name;
    EXPECT_NEAR(JsonNumber(r.out, name, per_factor_at), rank(per_factor, q), 1e-5) << name;
    weighted_differs |= rank(per_step, q) != rank(per_factor, q);
  }
  EXPECT_TRUE(weighted_differs);
  // --rate 20000: step i due at i / 20 ms, started when due and the one before has ended; each
  // of its factors waits from its due time to the step's end. Slots this short make the slower
  // steps hold up the next.
  std::vector<double> queued;
  double end_ms = 0.0;
  for (std::size_t i = 0; i < per_step.size(); ++i) {
    const double due_ms = 0.05 * static_cast<double>(i);
    end_ms = std::max(end_ms, due_ms) + per_step[i];
    queued.insert(queued.end(), step_factors[i], end_ms - due_ms);
  }
  const std::size_t queued_at = r.out.find("\"queued_ms\": ");
  ASSERT_NE(queued_at, std::string::npos) << r.out;
  EXPECT_EQ(JsonNumber(r.out, "rate_hz"), 20000.0);
  for (const auto& [q, name] : {std::pair{0.5, "p50"}, {0.99, "p99"}, {1.0, "max"}}) {
    EXPECT_NEAR(JsonNumber(r.out, name, queued_at), rank(queued, q), 1e-3) << name;  // CSV rounding
  }
  double waited_ms = 0.0;  // beyond the step's own time, over every message
  for (std::size_t i = 0; i < queued.size(); ++i) waited_ms += queued[i] - per_factor[i];
  EXPECT_GT(waited_ms, 0.0);
  std::filesystem::remove_all(dir);
  const SlamctlRun bad = RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") +
                                    " --solver isam2 --relinearize-skip 0");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.out.find("relinearization.skip"), std::string::npos) << bad.out;
}

// Growth windows (steps 500-1000 and the last 500): p50 of all steps and of the odometry-only
// steps. In a world without loop closures both are the same steps.
TEST(BenchTest, Isam2StepGrowthWindowsOfOdometryOnlySteps) {
  const std::string dir = ::testing::TempDir() + "slamd_bench_growth_" + std::to_string(getpid());
  ASSERT_EQ(RunSlamctl("sim manhattan --steps 1200 --loop-probability 0 -o " + dir).exit_code, 0);
  const SlamctlRun r = RunSlamctl("bench " + dir + "/world.g2o --solver isam2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto field = [&](const std::string& name) { return JsonNumber(r.out, name); };
  EXPECT_GT(field("p50_early_ms"), 0.0);
  EXPECT_GT(field("p50_late_ms"), 0.0);
  EXPECT_EQ(field("odometry_p50_early_ms"), field("p50_early_ms"));
  EXPECT_EQ(field("odometry_p50_late_ms"), field("p50_late_ms"));
  std::filesystem::remove_all(dir);
}

TEST(BenchTest, Isam2MarginalsAreTimed) {
  for (const char* mode : {"latest", "all"}) {
    const SlamctlRun r = RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") +
                                    " --solver isam2 --json --marginals " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    EXPECT_NE(r.out.find(std::string("\"marginals\": \"") + mode + "\""), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("\"marginal_ms\": {\"p50\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"marginals_final_all_ms\""), std::string::npos) << r.out;
  }
}

TEST(BenchTest, HumanSummaryAndOutputFile) {
  const std::string out = testing::WriteTempFile("solved.g2o", "");
  const SlamctlRun r =
      RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("chi2"), std::string::npos);
  const SlamctlRun again = RunSlamctl("bench " + out + " --json");
  EXPECT_EQ(again.exit_code, 0) << again.out;
}

TEST(BenchTest, ArgumentErrorsExitTwoWithAMessage) {
  SlamctlRun r = RunSlamctl("bench /no/such/file.g2o");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("/no/such/file.g2o"), std::string::npos) << r.out;
  r = RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --solver magic");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("magic"), std::string::npos) << r.out;
  r = RunSlamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --max-iterations 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("max_iterations"), std::string::npos) << r.out;
  r = RunSlamctl("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  r = RunSlamctl("bench --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--init"), std::string::npos);
}

TEST(BenchTest, CorruptDatasetFailsWithFileAndLine) {
  const std::string bad =
      testing::WriteTempFile("bad.g2o", "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 oops\n");
  const SlamctlRun r = RunSlamctl("bench " + bad);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find(":2:"), std::string::npos) << r.out;
}

// --robust and --ground-truth: on a small simulated world with 30% outlier loop
// closures the kernel brings the ATE back; both solvers report it; bad arguments exit 2.
TEST(BenchTest, RobustKernelAndGroundTruthAte) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("slamctl_bench_robust_" + std::to_string(getpid())))
                              .string();
  SlamctlRun r = RunSlamctl("sim manhattan --seed 3 --steps 300 --outliers 0.3 -o " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string world = dir + "/world.g2o",
                    truth = " --ground-truth " + dir + "/world_groundtruth.g2o";
  double ate_none[2], ate_cauchy[2];
  const char* solvers[] = {"batch", "isam2"};
  for (int s = 0; s < 2; ++s) {
    const std::string base = "bench " + world + " --json --solver " + solvers[s] + truth;
    r = RunSlamctl(base);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    ate_none[s] = JsonNumber(r.out, "ate_rmse");
    EXPECT_NE(r.out.find("\"robust\": \"none\""), std::string::npos) << r.out;
    const double loops = JsonNumber(r.out, "loop_closures");  // counted with or without a kernel
    r = RunSlamctl(base + " --robust cauchy:3");
    ASSERT_EQ(r.exit_code, 0) << r.out;
    for (const char* field : {"\"robust\": \"cauchy:3\"", "\"loop_closures\"", "\"ate_rmse\"",
                              "\"ate_max\"", "\"ate_poses\": 300"}) {
      EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
    }
    ate_cauchy[s] = JsonNumber(r.out, "ate_rmse");
    EXPECT_GT(JsonNumber(r.out, "loop_closures"), 10.0) << r.out;
    EXPECT_EQ(JsonNumber(r.out, "loop_closures"), loops);
    EXPECT_GE(JsonNumber(r.out, "ate_max"), ate_cauchy[s]);
    EXPECT_GT(ate_cauchy[s], 0.0);
    EXPECT_GT(ate_none[s], 5.0 * ate_cauchy[s]) << solvers[s];
  }
  r = RunSlamctl("bench " + world + " --robust dcs" + truth);  // human summary
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("robust kernel dcs:9 on the "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ATE vs "), std::string::npos) << r.out;
  for (const char* bad : {"--robust tukey", "--robust huber:-1", "--robust none:2",
                          "--ground-truth /no/such/truth.g2o"}) {
    r = RunSlamctl("bench " + world + " " + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.out;
  }
  // A ground truth sharing no pose with the dataset is an error of the run, not of the arguments.
  const std::string other = testing::WriteTempFile("other_truth.g2o", "VERTEX_SE2 5000 0 0 0\n");
  r = RunSlamctl("bench " + world + " --ground-truth " + other);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("share no pose"), std::string::npos) << r.out;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// Bundle adjustment of a BAL file: the JSON line has the cost as Ceres defines it, one entry per
// iteration, the time per phase, and -o writes the result.
TEST(BenchTest, BundleAdjustmentJsonAndOutput) {
  const std::string bal = std::string(SLAMD_SHARED_DATASETS) + "/bal/dubrovnik-3-7-pre.txt";
  if (!std::filesystem::exists(bal)) GTEST_SKIP() << bal << " not found";
  const std::string ply =
      ::testing::TempDir() + "slamd_bench_ba_" + std::to_string(getpid()) + ".ply";
  for (const char* solver : {"dense-schur", "sparse-schur", "iterative-schur"}) {
    const SlamctlRun r =
        RunSlamctl("bench " + bal + " --solver ba --json --linear-solver " + solver + " -o " + ply);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    EXPECT_NE(r.out.find(std::string("\"linear_solver\": \"") + solver), std::string::npos)
        << r.out;
    for (const char* field :
         {"\"initial_cost\"", "\"final_cost\"", "\"total_s\"", "\"iterations\": [{\"cost\"",
          "\"elapsed_s\"", "\"phase_s\"", "\"schur\"", "\"rms_reprojection_px\"", "\"peak_rss_mb\"",
          "\"points_retriangulated\""}) {
      EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
    }
    EXPECT_LT(JsonNumber(r.out, "final_cost"), JsonNumber(r.out, "initial_cost"));
    EXPECT_TRUE(std::filesystem::exists(ply));
    std::filesystem::remove(ply);
  }
  const SlamctlRun bad = RunSlamctl("bench " + bal + " --solver ba --linear-solver qr");
  EXPECT_NE(bad.exit_code, 0);
}

// Ladybug-49 camera by camera with its calibrations refined by Gauss-Newton at the default
// relinearisation skip diverges (each new camera's own calibration, seen by a few points): the
// run says so, on standard error and in the JSON line, and names the options that hold it.
TEST(BenchTest, Isam2SaysWhenAReconstructionDiverged) {
  const std::string bal = std::string(SLAMD_SHARED_DATASETS) + "/bal/problem-49-7776-pre.txt";
  if (!std::filesystem::exists(bal)) GTEST_SKIP() << bal << " not found";
  const SlamctlRun refined = RunSlamctl("bench " + bal + " --solver isam2 --json");
  ASSERT_EQ(refined.exit_code, 0) << refined.out;
  EXPECT_GT(JsonNumber(refined.out, "final_cost"), JsonNumber(refined.out, "initial_cost"));
  EXPECT_NE(refined.out.find("\"diverged\": true"), std::string::npos) << refined.out;
  EXPECT_NE(refined.out.find("warning: the estimate after the last step costs more"),
            std::string::npos)
      << refined.out;
  EXPECT_NE(refined.out.find("--fixed-intrinsics"), std::string::npos) << refined.out;
  const SlamctlRun held = RunSlamctl("bench " + bal + " --solver isam2 --json --fixed-intrinsics");
  ASSERT_EQ(held.exit_code, 0) << held.out;
  EXPECT_LT(JsonNumber(held.out, "final_cost"), JsonNumber(held.out, "initial_cost"));
  EXPECT_NE(held.out.find("\"diverged\": false"), std::string::npos) << held.out;
  EXPECT_EQ(held.out.find("warning"), std::string::npos) << held.out;
}

// A COLMAP model with one camera for every image: its calibration refined once (focal lengths;
// no skew, the principal point held) and the model written back as COLMAP reads it.
TEST(BenchTest, BundleAdjustmentOfAColmapModelWithASharedCamera) {
  testing::TempDir dir("slamd_bench_colmap_");
  const SlamctlRun sim =
      RunSlamctl("sim camera-object --cameras 10 --points 200 -o " + dir.File("world"));
  ASSERT_EQ(sim.exit_code, 0) << sim.out;
  const std::string model = dir.File("world/colmap");
  const SlamctlRun ba =
      RunSlamctl("bench " + model + " --solver ba --json -o " + dir.File("solved"));
  ASSERT_EQ(ba.exit_code, 0) << ba.out;
  EXPECT_EQ(JsonNumber(ba.out, "shared_calibrations"), 1.0);
  EXPECT_EQ(JsonNumber(ba.out, "camera_block_dim"), 6.0);
  const std::string cameras = testing::ReadFileBytes(dir.File("solved/cameras.txt"));
  EXPECT_NE(cameras.find("PINHOLE"), std::string::npos) << cameras;
  // Written back and read again: the adjuster starts at its optimum.
  const SlamctlRun again = RunSlamctl("bench " + dir.File("solved") + " --solver ba --json");
  ASSERT_EQ(again.exit_code, 0) << again.out;
  const double cost = JsonNumber(ba.out, "final_cost");
  EXPECT_NEAR(JsonNumber(again.out, "initial_cost"), cost, 1e-6 * cost);
  const SlamctlRun fixed = RunSlamctl("bench " + model + " --solver ba --json --fixed-intrinsics");
  ASSERT_EQ(fixed.exit_code, 0) << fixed.out;
  EXPECT_EQ(JsonNumber(fixed.out, "shared_calibrations"), 0.0);
  EXPECT_GE(JsonNumber(fixed.out, "final_cost"), cost * (1.0 - 1e-9));
}

// A BAL file as a factor graph: the batch solver eliminates the points first by
// default, to the same optimum as with COLAMD; Isam2 takes it camera by camera.
TEST(BenchTest, ReconstructionAsAGraphForBatchAndIsam2) {
  testing::TempDir dir("slamd_bench_sfm_");
  const SlamctlRun sim =
      RunSlamctl("sim camera-object --cameras 12 --points 300 -o " + dir.File("world"));
  ASSERT_EQ(sim.exit_code, 0) << sim.out;
  const std::string bal = dir.File("world/problem.bal");
  const SlamctlRun schur =
      RunSlamctl("bench " + bal + " --solver batch --json -o " + dir.File("solved.bal"));
  const SlamctlRun colamd = RunSlamctl("bench " + bal + " --solver batch --json --ordering colamd");
  ASSERT_EQ(schur.exit_code, 0) << schur.out;
  ASSERT_EQ(colamd.exit_code, 0) << colamd.out;
  const double points = JsonNumber(schur.out, "landmarks");
  EXPECT_GT(points, 100.0);
  EXPECT_EQ(JsonNumber(schur.out, "landmarks_first"), points);
  EXPECT_EQ(JsonNumber(colamd.out, "landmarks_first"), 0.0);
  const double chi2 = JsonNumber(colamd.out, "final_chi2");
  EXPECT_LT(chi2, 1e-2 * JsonNumber(colamd.out, "initial_chi2"));
  EXPECT_NEAR(JsonNumber(schur.out, "final_chi2"), chi2, 1e-6 * chi2);
  // The estimate written back: the batch solver starting there stays at its optimum.
  const SlamctlRun again = RunSlamctl("bench " + dir.File("solved.bal") + " --solver batch --json");
  ASSERT_EQ(again.exit_code, 0) << again.out;
  EXPECT_NEAR(JsonNumber(again.out, "initial_chi2"), chi2, 1e-6 * chi2);
  EXPECT_NE(RunSlamctl("bench " + bal + " --solver batch --ordering amd").exit_code, 0);

  // Isam2 camera by camera on the same file: every observation in, settled at the batch optimum
  // of the graph it built.
  const SlamctlRun isam2 = RunSlamctl("bench " + bal +
                                      " --solver isam2 --settle 5 --compare-batch --json "
                                      "--step-times " +
                                      dir.File("steps.csv"));
  ASSERT_EQ(isam2.exit_code, 0) << isam2.out;
  // One CSV line per camera after the header, the last one's cost the final cost.
  std::istringstream csv(testing::ReadFileBytes(dir.File("steps.csv")));
  std::string line, last;
  int lines = 0;
  for (; std::getline(csv, line); ++lines) last = line;
  EXPECT_EQ(lines, 13);
  EXPECT_NEAR(std::stod(last.substr(last.rfind(',') + 1)), JsonNumber(isam2.out, "final_cost"),
              1e-6 * JsonNumber(isam2.out, "final_cost"));
  EXPECT_EQ(JsonNumber(isam2.out, "failed_updates"), 0.0);
  EXPECT_EQ(JsonNumber(isam2.out, "steps"), 12.0);
  EXPECT_EQ(JsonNumber(isam2.out, "observations_in_graph"), JsonNumber(isam2.out, "observations"));
  EXPECT_GT(JsonNumber(isam2.out, "step_ms_p99"), 0.0);
  // Against the graph at the values its cameras and points entered with (the file's).
  EXPECT_LT(JsonNumber(isam2.out, "final_cost"), JsonNumber(isam2.out, "initial_cost"));
  EXPECT_NE(isam2.out.find("\"diverged\": false"), std::string::npos) << isam2.out;
  EXPECT_EQ(isam2.out.find("warning"), std::string::npos) << isam2.out;
  const double batch = JsonNumber(isam2.out, "batch_cost");
  EXPECT_NEAR(JsonNumber(isam2.out, "settled_cost"), batch, 1e-6 * batch);
  EXPECT_GE(JsonNumber(isam2.out, "final_cost"), batch * (1 - 1e-9));

  // Points whose rays are closer than 60 degrees at the estimate leave: every update succeeds,
  // every observation is in the graph or counted as dropped, and the rest settles at its batch
  // optimum.
  const SlamctlRun dropping = RunSlamctl("bench " + bal +
                                         " --solver isam2 --drop-parallax 60 --settle 5 "
                                         "--compare-batch --json");
  ASSERT_EQ(dropping.exit_code, 0) << dropping.out;
  EXPECT_EQ(JsonNumber(dropping.out, "failed_updates"), 0.0);
  EXPECT_GT(JsonNumber(dropping.out, "points_dropped"), 0.0);
  EXPECT_EQ(JsonNumber(dropping.out, "observations_in_graph") +
                JsonNumber(dropping.out, "observations_dropped"),
            JsonNumber(dropping.out, "observations"));
  const double rest = JsonNumber(dropping.out, "batch_cost");
  EXPECT_LT(rest, batch);
  EXPECT_NEAR(JsonNumber(dropping.out, "settled_cost"), rest, 1e-6 * rest);
}

}  // namespace
}  // namespace slamd::clients
