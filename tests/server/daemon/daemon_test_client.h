// Messages, a collecting client and parameters shared by the daemon's tests (daemon_test.cc,
// daemon_publish_test.cc).
#pragma once

#include <unistd.h>

#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "server/config/server_params.h"
#include "server/messages/inbound.h"
#include "server/transport/bus.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/estimate_t.hpp"
#include "slamd/reject_t.hpp"
#include "slamd/status_t.hpp"
#include "tests/testing/noise.h"

namespace slamd::server::daemon_test {

using ::slamd::testing::Noise;

inline slamd::odometry_t Odo(std::uint64_t from, std::uint64_t to, const std::string& robot = "r") {
  slamd::odometry_t msg;
  ToLcm(OdometryMeasurement{10, robot, from, to, core::Pose2(1, 0, 0.1), Noise(3, 0.1)}, &msg);
  return msg;
}

inline slamd::prior_t Prior(const std::string& robot = "r") {
  slamd::prior_t msg;
  ToLcm(PriorMeasurement{5, robot, 0, PriorKind::kPose2, core::Pose2(), Noise(3, 0.01)}, &msg);
  return msg;
}

// Collects what the daemon publishes (callbacks run on whichever thread handles the bus).
struct Client {
  explicit Client(Bus& bus) {
    subs.push_back(Subscribe<slamd::estimate_t>(
                       bus, "SLAMD_ESTIMATE",
                       [this](std::string_view, const slamd::estimate_t& m) {
                         std::lock_guard lock(mutex);
                         estimates.push_back(m);
                       },
                       nullptr)
                       .value());
    subs.push_back(Subscribe<slamd::reject_t>(
                       bus, "SLAMD_REJECT",
                       [this](std::string_view, const slamd::reject_t& m) {
                         std::lock_guard lock(mutex);
                         rejects.push_back(m);
                       },
                       nullptr)
                       .value());
    subs.push_back(Subscribe<slamd::status_t>(
                       bus, "SLAMD_STATUS",
                       [this](std::string_view, const slamd::status_t& m) {
                         std::lock_guard lock(mutex);
                         statuses.push_back(m);
                       },
                       nullptr)
                       .value());
  }
  std::mutex mutex;
  std::vector<slamd::estimate_t> estimates;
  std::vector<slamd::reject_t> rejects;
  std::vector<slamd::status_t> statuses;
  std::vector<Subscription> subs;
};

// A data directory for one test, named after it and this process, emptied first.
inline std::string FreshDataDir(const std::string& name) {
  const std::string dir = (std::filesystem::temp_directory_path() /
                           ("slamd_daemon_" + name + "_" + std::to_string(::getpid())))
                              .string();
  std::filesystem::remove_all(dir);
  return dir;
}

inline ServerParams Params() {
  ServerParams p;
  p.estimator.chi2_interval_s = 0.0;  // tests compare chi2 after each update
  p.refine.enabled = false;
  p.publish.status_rate_hz = 0.0;
  return p;
}

}  // namespace slamd::server::daemon_test
