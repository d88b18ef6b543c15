// Test helpers for tests that run executables (the netns integration tests):
//  * OnlyLoopback(): true when "lo" is the only network interface (/proc/self/net/dev), i.e.
//    inside the private namespace of scripts/netns-run. Tests that multicast refuse to run
//    otherwise, so they never send on a real network: ASSERT_TRUE(OnlyLoopback()) << kNotInNetns.
//  * Spawn(argv, output_path, streams): fork + execvp (argv[0] is looked up in PATH when it has
//    no slash). When output_path is not empty the child's stdout (and stderr with
//    Streams::kStdoutAndStderr) go to that file, truncated. Returns the pid, -1 when fork fails;
//    a child that cannot exec exits 127.
//  * WaitExit(pid): waits for the child; its exit code, or 128 + signal when a signal ended it
//    (-1 when waitpid fails).
//  * RunCommand(argv, streams, timeout_s, poll): runs argv to completion with its output captured
//    (through a temp file). poll() (when given) is called between checks for the exit, else the
//    check sleeps 5 ms. After timeout_s the child gets SIGKILL, the test fails (ADD_FAILURE) and
//    exit_code is -1.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace slamd::testing {

inline constexpr const char* kNotInNetns =
    "refusing to multicast outside a private network namespace; "
    "run through scripts/netns-run (ctest -L netns)";

inline bool OnlyLoopback() {
  std::ifstream in("/proc/self/net/dev");
  std::set<std::string> names;
  std::string line;
  for (int i = 0; std::getline(in, line); ++i) {  // two header lines, then "  name: counters"
    const size_t colon = line.find(':');
    if (i < 2 || colon == std::string::npos) continue;
    const size_t start = line.find_first_not_of(' ');
    names.insert(line.substr(start, colon - start));
  }
  return names == std::set<std::string>{"lo"};
}

enum class Streams { kStdout, kStdoutAndStderr };

inline pid_t Spawn(const std::vector<std::string>& argv, const std::string& output_path = "",
                   Streams streams = Streams::kStdout) {
  const pid_t pid = fork();
  if (pid == 0) {
    if (!output_path.empty()) {
      const int fd = open(output_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        dup2(fd, STDOUT_FILENO);
        if (streams == Streams::kStdoutAndStderr) dup2(fd, STDERR_FILENO);
      }
    }
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
  return pid;
}

// The exit code of a waitpid status, or 128 + signal (as a shell reports it).
inline int ExitCode(int status) {
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

inline int WaitExit(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return ExitCode(status);
}

struct CommandRun {
  int exit_code = -1;
  std::string out;
};

inline CommandRun RunCommand(const std::vector<std::string>& argv, Streams streams,
                             double timeout_s, const std::function<void()>& poll = nullptr) {
  static std::atomic<int> counter{0};
  const std::string out_path = ::testing::TempDir() + "slamd_command_out_" +
                               std::to_string(getpid()) + "_" + std::to_string(counter++);
  const pid_t pid = Spawn(argv, out_path, streams);
  CommandRun run;
  if (pid < 0) {
    ADD_FAILURE() << "fork failed";
    return run;
  }
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      ADD_FAILURE() << argv[0] << " timed out";
      std::remove(out_path.c_str());
      return run;
    }
    if (poll) {
      poll();
    } else {
      usleep(5000);
    }
  }
  run.exit_code = ExitCode(status);
  std::ifstream in(out_path);
  std::stringstream text;
  text << in.rdbuf();
  run.out = text.str();
  std::remove(out_path.c_str());
  return run;
}

}  // namespace slamd::testing
