// slamctl watch: a live view of slamd in the terminal: the latest status_t and, per robot, its
// newest estimate_t (pose, update, latency, estimates per second), redrawn every --period until
// Ctrl-C or --duration. On a terminal the screen is redrawn in place; otherwise (a pipe, a log)
// each refresh is printed as a block.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "clients/slamctl/client_common.h"
#include "slamd/estimate_t.hpp"

namespace slamd::clients {
namespace {

constexpr const char* kWatchCommand = "watch";

std::atomic<bool> g_interrupted{false};
extern "C" void OnInterrupt(int) { g_interrupted = true; }

struct WatchOptions {
  double duration_s = 0.0;  // 0 = until Ctrl-C
  double period_s = 0.5;
  ConnectionOptions connection;
};

struct RobotView {
  slamd::estimate_t last;
  std::int64_t count = 0;           // estimates since start
  std::int64_t count_at_frame = 0;  // at the previous frame (for the rate)
  double received_s = 0;
};

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string Frame(const std::optional<slamd::status_t>& status,
                  std::map<std::string, RobotView>* robots, double now_s, double frame_dt,
                  const std::string& url) {
  std::string out = "slamd on " + url + "\n";
  if (status) {
    out += FormatStatus(*status);
  } else {
    out += "(no status_t yet)\n";
  }
  char buf[512];
  std::snprintf(buf, sizeof(buf), "\n%-16s %10s %9s %9s %9s %8s %9s %7s %6s\n", "robot", "pose",
                "x", "y", "z/theta", "update", "latency", "est/s", "age");
  out += buf;
  if (robots->empty()) out += "(no estimate_t yet)\n";
  for (auto& [name, view] : *robots) {
    const slamd::estimate_t& e = view.last;
    const double x = e.values.size() > 0 ? e.values[0] : 0.0;
    const double y = e.values.size() > 1 ? e.values[1] : 0.0;
    const double zt = e.values.size() > 2 ? e.values[2] : 0.0;
    const double rate =
        frame_dt > 0 ? static_cast<double>(view.count - view.count_at_frame) / frame_dt : 0.0;
    view.count_at_frame = view.count;
    std::snprintf(buf, sizeof(buf),
                  "%-16.16s %10lld %9.3f %9.3f %9.3f %8lld %7.2fms %7.1f %5.1fs\n", name.c_str(),
                  static_cast<long long>(e.pose_index), x, y, zt,
                  static_cast<long long>(e.update_sequence), e.latency_us / 1e3, rate,
                  now_s - view.received_s);
    out += buf;
  }
  return out;
}

void RunWatch(const WatchOptions& opt) {
  server::ChannelNames channels;
  std::unique_ptr<LcmClient> client = ConnectOrFail(kWatchCommand, opt.connection, &channels);
  std::optional<slamd::status_t> status;
  std::map<std::string, RobotView> robots;
  for (const core::Status& s :
       {client->Subscribe<slamd::status_t>(channels.Status(),
                                           [&](const slamd::status_t& m) { status = m; }),
        client->Subscribe<slamd::estimate_t>(channels.Estimate(), [&](const slamd::estimate_t& m) {
          RobotView& v = robots[m.robot];
          v.last = m;
          ++v.count;
          v.received_s = Now();
        })}) {
    if (!s.ok()) CommandFail(kWatchCommand, kExitFailure, s.ToString());
  }
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  const bool tty = StdoutIsTty();
  const double start = Now();
  double last_frame = start;
  while (!g_interrupted) {
    const double now = Now();
    const bool over = opt.duration_s > 0 && now - start >= opt.duration_s;
    const double next =
        std::min(last_frame + opt.period_s, opt.duration_s > 0 ? start + opt.duration_s : 1e300);
    core::Result<bool> r = client->HandleUntil([&] { return g_interrupted || Now() >= next; },
                                               std::max(0.0, next - now));
    if (!r.ok()) CommandFail(kWatchCommand, kExitFailure, r.status().ToString());
    const double t = Now();
    const std::string frame = Frame(status, &robots, t, t - last_frame, client->url());
    last_frame = t;
    if (tty) {
      std::fputs("\x1b[H\x1b[2J", stdout);  // home, clear screen
      std::fputs(frame.c_str(), stdout);
    } else {
      std::fputs((frame + "\n").c_str(), stdout);
    }
    std::fflush(stdout);
    if (over || (opt.duration_s > 0 && t - start >= opt.duration_s)) break;
  }
}

}  // namespace

void RegisterWatch(CLI::App& app) {
  auto opt = std::make_shared<WatchOptions>();
  CLI::App* cmd = app.add_subcommand(
      "watch", "Live view of slamd: its status and each robot's newest estimate, until Ctrl-C");
  cmd->add_option("--duration", opt->duration_s, "Stop after this many seconds (0: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--period", opt->period_s, "Refresh period [s]")
      ->check(CLI::Range(0.01, 3600.0))
      ->capture_default_str();
  AddConnectionOptions(cmd, &opt->connection);
  cmd->callback([opt] { RunWatch(*opt); });
}

}  // namespace slamd::clients
