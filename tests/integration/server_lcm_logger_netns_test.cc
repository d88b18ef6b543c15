// lcm-logger (LCM's own recorder) records a session with the real slamd — the example publisher
// (clients/examples) as the robot — and every event of the log decodes as the type its channel
// carries: the server's output (estimate_t, status_t) and the robot's input. Runs inside a
// private network namespace (ctest label netns; udpm with ttl=0).
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "slamd/estimate_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/processes.h"

namespace {

using slamd::testing::Spawn;
using slamd::testing::WaitExit;

constexpr const char* kUrl = "udpm://239.255.76.67:7667?ttl=0";
// The logger's socket buffer as large as the kernel allows by default here (rmem_max 4 MiB):
// with the default 208 KiB, a logger descheduled while the suite ran on both cores lost
// datagrams (5 of 20 odometry messages and the loop closure, once), which slamd had received.
constexpr const char* kLoggerUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304";

template <typename Msg>
bool Decodes(const lcm::LogEvent& e) {
  Msg m;
  return m.decode(e.data, 0, e.datalen) == e.datalen;
}

// The log's events per SLAMD_ channel, and how many of them decode as their channel's type.
struct Counts {
  std::map<std::string, int> events, decoded;
};

Counts Read(const std::string& log) {
  Counts counts;
  lcm::LogFile file(log, "r");
  if (!file.good()) return counts;
  for (const lcm::LogEvent* e = file.readNextEvent(); e != nullptr; e = file.readNextEvent()) {
    if (e->channel.rfind("SLAMD_", 0) != 0) continue;  // LCM's own LCM_SELF_TEST
    ++counts.events[e->channel];
    bool ok = false;
    if (e->channel == "SLAMD_ESTIMATE") ok = Decodes<slamd::estimate_t>(*e);
    if (e->channel == "SLAMD_STATUS") ok = Decodes<slamd::status_t>(*e);
    if (e->channel == "SLAMD_ODOMETRY") ok = Decodes<slamd::odometry_t>(*e);
    if (e->channel == "SLAMD_PRIOR") ok = Decodes<slamd::prior_t>(*e);
    if (e->channel == "SLAMD_LOOP_CLOSURE") ok = Decodes<slamd::loop_closure_t>(*e);
    counts.decoded[e->channel] += ok;
  }
  return counts;
}

// What the example publisher's session must leave in the log.
bool Complete(Counts c) {
  return c.events["SLAMD_ODOMETRY"] >= 20 && c.events["SLAMD_PRIOR"] >= 1 &&
         c.events["SLAMD_LOOP_CLOSURE"] >= 1 && c.events["SLAMD_ESTIMATE"] >= 21 &&
         c.events["SLAMD_STATUS"] >= 1;
}

TEST(ServerLcmLoggerTest, LoggerRecordsTheSessionAndEveryEventDecodes) {
  const std::string log = std::filesystem::temp_directory_path() /
                          ("slamd_lcm_logger_" + std::to_string(getpid()) + ".lcmlog");
  std::filesystem::remove(log);
  const pid_t logger =
      Spawn({"lcm-logger", "--quiet", std::string("--lcm-url=") + kLoggerUrl, log});
  const pid_t slamd = Spawn({SLAMD_PATH, "--lcm-url", kUrl, "--log-level", "warn"});
  // Both up before the robot talks: the logger has created its file and slamd's first
  // status_t has gone out (on a loaded machine either can take a while).
  {
    lcm::LCM lcm(kUrl);
    bool status = false;
    lcm.subscribeFunction(
        "SLAMD_STATUS",
        +[](const lcm::ReceiveBuffer*, const std::string&, bool* seen) { *seen = true; }, &status);
    for (int waited_ms = 0; waited_ms < 10000 && !(status && std::filesystem::exists(log));
         waited_ms += 50) {
      lcm.handleTimeout(50);
    }
    ASSERT_TRUE(status && std::filesystem::exists(log)) << "slamd or lcm-logger did not start";
  }
  const pid_t robot = Spawn({SLAMD_EXAMPLE_PUBLISHER_PATH, kUrl});
  ASSERT_EQ(WaitExit(robot), 0);
  // The logger writes what it received every 100 ms; on a loaded machine slamd's last estimates
  // and the logger's writes can lag the robot by seconds. Wait until the session is in the file
  // (a loss shows as a timeout with the counts below), then stop both.
  for (int waited_ms = 0; waited_ms < 20000 && !Complete(Read(log)); waited_ms += 100) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(slamd, SIGTERM);
  EXPECT_EQ(WaitExit(slamd), 0);
  kill(logger, SIGINT);
  WaitExit(logger);

  ASSERT_TRUE(lcm::LogFile(log, "r").good()) << log;
  auto [events, decoded] = Read(log);
  std::filesystem::remove(log);
  EXPECT_EQ(events["SLAMD_ODOMETRY"], 20);
  EXPECT_EQ(events["SLAMD_PRIOR"], 1);
  EXPECT_EQ(events["SLAMD_LOOP_CLOSURE"], 1);
  EXPECT_GE(events["SLAMD_ESTIMATE"], 21);  // one per pose, one after the loop closure
  EXPECT_GE(events["SLAMD_STATUS"], 1);
  EXPECT_EQ(events.count("SLAMD_REJECT"), 0u);
  for (const auto& [channel, n] : events) {
    EXPECT_EQ(decoded[channel], n) << channel << ": not every event decodes";
  }
}

}  // namespace
