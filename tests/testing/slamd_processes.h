// Test helpers that run real `slamd` processes and talk to them over LCM (the netns and ha
// integration tests; SLAMD_PATH is the daemon's path):
//  * TempDir: a directory for data directories, configs and logs, kept when the test failed
//    (or SLAMD_KEEP_TMP is set).
//  * Server: one slamd as the client sees it (its prefix, data directory, log, pid, and what it
//    published: estimates, rejections, query replies, status).
//  * Client: one LCM bus that listens to servers (Attach) and sends them steps; PumpUntil,
//    Drain, Barrier (a query through a server's queue: its reply means everything sent before
//    it was processed).
//  * Launch, Start (waits for the first status_t), WaitForLog, Kill (SIGTERM must exit 0),
//    KillOnExit (no process outlives a failed test),
//    SendUntilEstimated (a robot's lock-step with re-sends), WallUs, ConfigParams.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/base/check.h"
#include "server/config/config_loader.h"
#include "server/messages/inbound.h"
#include "server/transport/lcm_bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/query_reply_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/wire_steps.h"

namespace slamd::testing {

using server::KeyKind;
using server::LcmBus;
using server::LcmBusParams;
using server::QueryRequest;
using server::Subscription;
using server::WireKey;

class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    path_ = std::filesystem::temp_directory_path() /
            ("slamd_" + tag + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    // Kept for a post-mortem when the test failed or SLAMD_KEEP_TMP is set.
    if (!::testing::Test::HasFailure() && !std::getenv("SLAMD_KEEP_TMP")) {
      std::filesystem::remove_all(path_);
    }
  }
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

inline std::int64_t WallUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// One slamd process as the client sees it.
struct Server {
  std::string prefix;
  std::string data_dir;
  std::string log;
  pid_t pid = -1;
  std::set<std::uint64_t> estimated = {};  // pose indices with an estimate_t since Clear()
  std::int64_t estimate_received_us = 0;   // when the last estimate_t arrived [µs, wall clock]
  std::map<std::int64_t, int> dups = {};   // REASON_DUPLICATE rejects by message_utime
  int other_rejects = 0;                   // rejects of any other reason
  std::map<int, int> rejects = {};         // every reject by reason
  std::int64_t reply_id = -1;              // last query_reply_t request_id
  std::int64_t status_utime = 0;           // of the last status_t
  slamd::status_t status = {};
  std::vector<Subscription> subs = {};
};

class Client {
 public:
  // `url`: the LCM URL of the servers (udpm with ttl=0, inside the test's namespace);
  // `barrier_robot`: a robot whose pose 0 the Barrier query asks for.
  Client(std::string url, std::string barrier_robot)
      : url_(std::move(url)),
        barrier_robot_(std::move(barrier_robot)),
        bus_(LcmBus::Create(LcmBusParams{.url = url_}).value()) {}
  const std::string& url() const { return url_; }

  void Attach(Server* s) {
    s->subs.push_back(server::Subscribe<slamd::estimate_t>(
                          *bus_, s->prefix + "ESTIMATE",
                          [s](std::string_view, const slamd::estimate_t& m) {
                            s->estimated.insert(static_cast<std::uint64_t>(m.pose_index));
                            s->estimate_received_us = WallUs();
                          },
                          nullptr)
                          .value());
    s->subs.push_back(server::Subscribe<slamd::reject_t>(
                          *bus_, s->prefix + "REJECT",
                          [s](std::string_view, const slamd::reject_t& m) {
                            ++s->rejects[m.reason];
                            if (m.reason == slamd::reject_t::REASON_DUPLICATE) {
                              ++s->dups[m.message_utime];
                            } else {
                              ++s->other_rejects;
                            }
                          },
                          nullptr)
                          .value());
    s->subs.push_back(
        server::Subscribe<slamd::query_reply_t>(
            *bus_, s->prefix + "QUERY_REPLY",
            [s](std::string_view, const slamd::query_reply_t& m) { s->reply_id = m.request_id; },
            nullptr)
            .value());
    s->subs.push_back(server::Subscribe<slamd::status_t>(
                          *bus_, s->prefix + "STATUS",
                          [s](std::string_view, const slamd::status_t& m) {
                            s->status = m;
                            s->status_utime = m.utime;
                          },
                          nullptr)
                          .value());
  }

  void Send(const Server& s, const StepMessages& step) {
    for (const WireMessage& m : step) {
      ASSERT_TRUE(bus_->Publish(s.prefix + m.suffix, m.bytes).ok());
    }
  }

  // Handles incoming messages until `done()` or the timeout; returns done().
  bool PumpUntil(const std::function<bool()>& done, double timeout_s) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!done()) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      if (!bus_->HandleOnce(20).ok()) return false;
    }
    return true;
  }
  // Handles what has arrived, without waiting.
  void Poll() {
    for (core::Result<int> r = bus_->HandleOnce(0); r.ok() && r.value() > 0;
         r = bus_->HandleOnce(0)) {
    }
  }
  void Drain(int ms) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    while (std::chrono::steady_clock::now() < deadline) (void)bus_->HandleOnce(5);
  }

  // A query through B's queue: its reply means everything sent before it was processed.
  bool Barrier(Server* s) {
    slamd::query_t q;
    server::ToLcm(QueryRequest{.utime = 0,
                               .client = "test_client",
                               .request_id = ++request_id_,
                               .keys = {WireKey{barrier_robot_, KeyKind::kPose, 0}}},
                  &q);
    if (!server::Publish(*bus_, s->prefix + "QUERY", q).ok()) return false;
    const std::int64_t id = request_id_;
    return PumpUntil([&] { return s->reply_id == id; }, 20.0);
  }

 private:
  std::string url_, barrier_robot_;
  std::unique_ptr<LcmBus> bus_;
  std::int64_t request_id_ = 0;
};

// Kills (SIGKILL) the servers' processes still running when it goes out of scope: a test that
// fails half-way leaves none behind.
class KillOnExit {
 public:
  explicit KillOnExit(std::vector<Server*> servers) : servers_(std::move(servers)) {}
  ~KillOnExit() {
    for (Server* s : servers_) {
      if (s->pid <= 0) continue;
      ::kill(s->pid, SIGKILL);
      ::waitpid(s->pid, nullptr, 0);
      s->pid = -1;
    }
  }
  KillOnExit(const KillOnExit&) = delete;
  KillOnExit& operator=(const KillOnExit&) = delete;

 private:
  std::vector<Server*> servers_;
};

// Sends `step` to s until the estimate of `pose` comes, re-sending it every resend_s without
// one (what a robot does with unacknowledged messages); the number of sends, 0 when it never
// came within timeout_s.
inline int SendUntilEstimated(Client& client, Server* s, const StepMessages& step,
                              std::uint64_t pose, double timeout_s, double resend_s) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<int>(timeout_s * 1e3));
  for (int sends = 1; std::chrono::steady_clock::now() < deadline; ++sends) {
    client.Send(*s, step);
    if (client.PumpUntil([&] { return s->estimated.count(pose) > 0; }, resend_s)) return sends;
  }
  return 0;
}

// Starts slamd on s's data dir (its stderr appended to s->log) without waiting.
inline void Launch(const std::string& config, const Client& client, Server* s) {
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(s->log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) ::dup2(fd, 2);
    execl(SLAMD_PATH, SLAMD_PATH, "--config", config.c_str(), "--lcm-url", client.url().c_str(),
          "--data-dir", s->data_dir.c_str(), "--channel-prefix", s->prefix.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  s->pid = pid;
}

// Starts slamd on s's data dir and waits until it listens (its first status_t: slamd recovers
// and subscribes before its threads start).
inline void Start(const std::string& config, Client& client, Server* s) {
  const std::int64_t t0 = WallUs();
  ASSERT_NO_FATAL_FAILURE(Launch(config, client, s));
  ASSERT_TRUE(client.PumpUntil([&] { return s->status_utime > t0; }, 30.0))
      << "no status_t from slamd " << s->prefix << " (log " << s->log << ")";
}

// Whether s's log contains `text`, waiting up to timeout_s while the client pumps.
inline bool WaitForLog(Client& client, const Server& s, const std::string& text, double timeout_s) {
  return client.PumpUntil(
      [&] {
        std::ifstream in(s.log);
        const std::string log{std::istreambuf_iterator<char>(in), {}};
        return log.find(text) != std::string::npos;
      },
      timeout_s);
}

inline void Kill(Server* s, int signal) {
  ASSERT_GT(s->pid, 0);
  ASSERT_EQ(::kill(s->pid, signal), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(s->pid, &status, 0), s->pid);
  if (signal == SIGTERM) {
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "slamd " << s->prefix << " did not stop cleanly (log " << s->log << ")";
  } else {
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal);
  }
  s->pid = -1;
}

inline server::ServerParams ConfigParams(const std::string& config_path) {
  core::Result<server::ServerParams> p = server::LoadConfigFile(config_path);
  SLAMD_CHECK(p.ok()) << p.status().ToString();
  return p.value();
}

}  // namespace slamd::testing
