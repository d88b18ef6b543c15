// Runs the slamctl binary: `slamctl bench` on a small dataset, and its argument errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
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

}  // namespace
}  // namespace slamd::clients
