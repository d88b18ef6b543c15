// Runs the slamctl binary: `slamctl bench` on a small dataset, and its argument errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/testing/datasets.h"

namespace slamd::clients {
namespace {

struct CommandRun {
  int exit_code;
  std::string out;  // stdout and stderr
};

CommandRun Slamctl(const std::string& args) {
  const std::string command = std::string(SLAMCTL_PATH) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  CommandRun run{-1, ""};
  if (pipe == nullptr) return run;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) run.out.append(buf.data(), n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

TEST(BenchTest, JsonHasTheDocumentedFields) {
  const CommandRun r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* field : {"\"dataset\"", "\"poses\"", "\"landmarks\"", "\"factors\"", "\"solver\": \"batch\"",
                            "\"iterations\"", "\"initial_chi2\"", "\"final_chi2\"", "\"total_s\"",
                            "\"peak_rss_mb\"", "\"termination\": \"converged\""}) {
    EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
  }
  EXPECT_EQ(r.out.front(), '{');
}

TEST(BenchTest, Isam2JsonHasStepPercentilesAndSettles) {
  const std::string csv = testing::WriteTempFile("steps.csv", "");
  const CommandRun r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") +
                               " --solver isam2 --json --compare-batch --settle 1 --step-times " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  for (const char* field : {"\"solver\": \"isam2\"", "\"step_ms\": {\"p50\"", "\"p90\"", "\"p99\"",
                            "\"max\"", "\"final_chi2\"", "\"chi2_before_settle\"", "\"batch_chi2\"",
                            "\"relinearized_total\"", "\"peak_rss_mb\""}) {
    EXPECT_NE(r.out.find(field), std::string::npos) << field << " missing from " << r.out;
  }
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "step,pose,ms,relinearized,reeliminated");
  int lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  EXPECT_GT(lines, 1);
  const CommandRun bad = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") +
                                 " --solver isam2 --relinearize-skip 0");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.out.find("relinearization.skip"), std::string::npos) << bad.out;
}

TEST(BenchTest, Isam2MarginalsAreTimed) {
  for (const char* mode : {"latest", "all"}) {
    const CommandRun r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") +
                                 " --solver isam2 --json --marginals " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    EXPECT_NE(r.out.find(std::string("\"marginals\": \"") + mode + "\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"marginal_ms\": {\"p50\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"marginals_final_all_ms\""), std::string::npos) << r.out;
  }
}

TEST(BenchTest, HumanSummaryAndOutputFile) {
  const std::string out = testing::WriteTempFile("solved.g2o", "");
  const CommandRun r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("chi2"), std::string::npos);
  const CommandRun again = Slamctl("bench " + out + " --json");
  EXPECT_EQ(again.exit_code, 0) << again.out;
}

TEST(BenchTest, ArgumentErrorsExitTwoWithAMessage) {
  CommandRun r = Slamctl("bench /no/such/file.g2o");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("/no/such/file.g2o"), std::string::npos) << r.out;
  r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --solver magic");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("magic"), std::string::npos) << r.out;
  r = Slamctl("bench " + testing::TestDataPath("small_slam2d.g2o") + " --max-iterations 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("max_iterations"), std::string::npos) << r.out;
  r = Slamctl("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  r = Slamctl("bench --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--init"), std::string::npos);
}

TEST(BenchTest, CorruptDatasetFailsWithFileAndLine) {
  const std::string bad = testing::WriteTempFile("bad.g2o", "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 oops\n");
  const CommandRun r = Slamctl("bench " + bad);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find(":2:"), std::string::npos) << r.out;
}

// --robust and --ground-truth (issue #9): on a small simulated world with 30% outlier loop
// closures the kernel brings the ATE back; both solvers report it; bad arguments exit 2.
double JsonNumber(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1.0;
  return std::strtod(json.c_str() + at + key.size() + 4, nullptr);
}

TEST(BenchTest, RobustKernelAndGroundTruthAte) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("slamctl_bench_robust_" + std::to_string(getpid()))).string();
  CommandRun r = Slamctl("sim manhattan --seed 3 --steps 300 --outliers 0.3 -o " + dir);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const std::string world = dir + "/world.g2o", truth = " --ground-truth " + dir + "/world_groundtruth.g2o";
  double ate_none[2], ate_cauchy[2];
  const char* solvers[] = {"batch", "isam2"};
  for (int s = 0; s < 2; ++s) {
    const std::string base = "bench " + world + " --json --solver " + solvers[s] + truth;
    r = Slamctl(base);
    ASSERT_EQ(r.exit_code, 0) << r.out;
    ate_none[s] = JsonNumber(r.out, "ate_rmse");
    EXPECT_NE(r.out.find("\"robust\": \"none\""), std::string::npos) << r.out;
    const double loops = JsonNumber(r.out, "loop_closures");  // counted with or without a kernel
    r = Slamctl(base + " --robust cauchy:3");
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
  r = Slamctl("bench " + world + " --robust dcs" + truth);  // human summary
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("robust kernel dcs:9 on the "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ATE vs "), std::string::npos) << r.out;
  for (const char* bad : {"--robust tukey", "--robust huber:-1", "--robust none:2", "--ground-truth /no/such/truth.g2o"}) {
    r = Slamctl("bench " + world + " " + bad);
    EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.out;
  }
  // A ground truth sharing no pose with the dataset is an error of the run, not of the arguments.
  const std::string other = testing::WriteTempFile("other_truth.g2o", "VERTEX_SE2 5000 0 0 0\n");
  r = Slamctl("bench " + world + " --ground-truth " + other);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("share no pose"), std::string::npos) << r.out;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

}  // namespace
}  // namespace slamd::clients
