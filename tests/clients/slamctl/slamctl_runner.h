// Test helper: runs the slamctl binary (SLAMCTL_PATH) with arguments and captures its exit code
// and output (stdout and stderr together, or stdout alone); ExpectUsageError checks that a
// command's arguments are refused.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace slamd::testing {

struct SlamctlRun {
  int exit_code = -1;
  std::string out;
};

// `args` is passed through the shell (quote what needs quoting). Never use a udpm URL here: tests
// outside a network namespace may only use memq:// (or fail before connecting).
inline SlamctlRun RunSlamctl(const std::string& args, bool merge_stderr = true) {
  const std::string command =
      std::string(SLAMCTL_PATH) + " " + args + (merge_stderr ? " 2>&1" : " 2>/dev/null");
  SlamctlRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) run.out.append(buf.data(), n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

// Expects `slamctl <command> <args>` to exit 2 (a usage error) with `message` in its output.
inline void ExpectUsageError(const std::string& command, const std::string& args,
                             const std::string& message) {
  const SlamctlRun run = RunSlamctl(command + " " + args);
  EXPECT_EQ(run.exit_code, 2) << command << " " << args << "\n" << run.out;
  EXPECT_NE(run.out.find(message), std::string::npos) << command << " " << args << "\n" << run.out;
}

}  // namespace slamd::testing
