#include "tests/benchmarks/ba_compare_run.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

namespace slamd::benchmarks {
namespace {

double CurrentRssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;  // kB
  }
  return Run::kNaN;
}

std::string OneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

// The child's report: numbers in shortest round-trip form (NaN included, which iostreams
// cannot read back), then the two strings on lines of their own.
std::string Encode(const Run& run) {
  std::string out;
  auto add = [&out](double v) {
    char buffer[32];
    out.append(buffer, std::to_chars(buffer, buffer + sizeof buffer, v).ptr);
    out += ' ';
  };
  for (double v : {run.ok ? 1.0 : 0.0, run.initial_cost, run.final_cost, run.total_s, run.solve_s,
                   run.start_rss_mb, static_cast<double>(run.trace.size())}) {
    add(v);
  }
  for (const auto& [t, cost] : run.trace) {
    add(t);
    add(cost);
  }
  return out + "\n" + OneLine(run.linear_solver) + "\n" + OneLine(run.message) + "\n";
}

std::optional<Run> Decode(const std::string& text) {
  std::istringstream in(text);
  auto next = [&in](double* v) {
    std::string token;
    if (!(in >> token)) return false;
    return std::from_chars(token.data(), token.data() + token.size(), *v).ec == std::errc();
  };
  Run run;
  double ok = 0.0, trace_size = 0.0;
  for (double* v : {&ok, &run.initial_cost, &run.final_cost, &run.total_s, &run.solve_s,
                    &run.start_rss_mb, &trace_size}) {
    if (!next(v)) return std::nullopt;
  }
  run.ok = ok != 0.0;
  run.trace.resize(static_cast<size_t>(trace_size));
  for (auto& [t, cost] : run.trace) {
    if (!next(&t) || !next(&cost)) return std::nullopt;
  }
  in.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  if (!std::getline(in, run.linear_solver) || !std::getline(in, run.message)) return std::nullopt;
  return run;
}

void WriteAll(int fd, const std::string& text) {
  for (size_t done = 0; done < text.size();) {
    const ssize_t n = write(fd, text.data() + done, text.size() - done);
    if (n <= 0) return;  // the parent then finds the report incomplete
    done += static_cast<size_t>(n);
  }
}

}  // namespace

Run FailedRun(std::string message) {
  Run run;
  run.message = std::move(message);
  return run;
}

Run RunInChild(const std::function<Run()>& solve) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return FailedRun("pipe() failed");
  std::fflush(nullptr);  // else both processes would write what is still buffered
  const pid_t pid = fork();
  if (pid < 0) return FailedRun("fork() failed");
  if (pid == 0) {
    close(pipe_fds[0]);
    const double start_rss_mb = CurrentRssMb();
    Run run = solve();
    run.start_rss_mb = start_rss_mb;
    WriteAll(pipe_fds[1], Encode(run));
    _exit(0);  // not exit(): the atexit handlers and stdio buffers are the parent's business
  }
  close(pipe_fds[1]);
  std::string report;
  char buffer[4096];
  for (ssize_t n; (n = read(pipe_fds[0], buffer, sizeof buffer)) > 0;) report.append(buffer, n);
  close(pipe_fds[0]);
  int status = 0;
  rusage usage{};
  if (wait4(pid, &status, 0, &usage) != pid) return FailedRun("wait4() failed");
  if (WIFSIGNALED(status)) {
    return FailedRun("the solver's process died of signal " + std::to_string(WTERMSIG(status)));
  }
  std::optional<Run> run = Decode(report);
  if (!run) return FailedRun("the solver's process sent no complete report");
  run->peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // KiB on Linux
  return *run;
}

}  // namespace slamd::benchmarks
