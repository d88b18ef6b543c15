// The smallest robot-side program that uses slamd: anchor a robot with a prior, send 2D
// odometry for a square path and a loop closure back to the start, wait for each estimate.
// It uses only LCM and the generated message types (msgs/lcm/*.lcm), as a robot's own code
// would; build it with the project (target slamd_example_publisher) or copy it.
//
//   slamd_example_publisher [LCM_URL]     (default: LCM's default, udpm://239.255.76.67:7667)
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "slamd/estimate_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/reject_t.hpp"

namespace {

// Row-major diagonal covariance for (x, y, theta).
std::vector<double> Diagonal(double sxy, double stheta) {
  return {sxy * sxy, 0, 0, 0, sxy * sxy, 0, 0, 0, stheta * stheta};
}

std::int64_t Now() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Listener {
  std::int64_t latest_index = -1;
  slamd::estimate_t latest;
  int rejects = 0;
  void OnEstimate(const lcm::ReceiveBuffer*, const std::string&, const slamd::estimate_t* m) {
    if (m->robot != "demo") return;
    latest_index = m->pose_index;
    latest = *m;
  }
  void OnReject(const lcm::ReceiveBuffer*, const std::string&, const slamd::reject_t* m) {
    std::fprintf(stderr, "rejected %s: %s\n", m->message_type.c_str(), m->detail.c_str());
    ++rejects;
  }
};

}  // namespace

int main(int argc, char** argv) {
  lcm::LCM lcm(argc > 1 ? argv[1] : "");
  if (!lcm.good()) {
    std::fprintf(stderr, "LCM could not start (is there a multicast route?)\n");
    return 1;
  }
  Listener listener;
  lcm.subscribe("SLAMD_ESTIMATE", &Listener::OnEstimate, &listener);
  lcm.subscribe("SLAMD_REJECT", &Listener::OnReject, &listener);

  // Pose 0 of robot "demo" is the origin, known to 1 cm / 0.01 rad.
  slamd::prior_t prior;
  prior.utime = Now();
  prior.robot = "demo";
  prior.pose_index = 0;
  prior.kind = slamd::prior_t::KIND_POSE_2D;
  prior.values = {0.0, 0.0, 0.0};
  prior.num_values = 3;
  prior.covariance = Diagonal(0.01, 0.01);
  prior.num_covariance = 9;
  lcm.publish("SLAMD_PRIOR", &prior);

  // Four sides of 5 steps of 1 m, turning 90 degrees at each corner; the odometry is biased a
  // little, the loop closure says pose 20 is back at pose 0.
  for (int i = 0; i < 20; ++i) {
    slamd::odometry_t odo;
    odo.utime = Now();
    odo.robot = "demo";
    odo.from_index = i;
    odo.to_index = i + 1;
    odo.dimension = slamd::odometry_t::DIMENSION_2D;
    odo.values = {1.02, 0.0, (i % 5 == 4) ? M_PI / 2 + 0.01 : 0.0};
    odo.num_values = 3;
    odo.covariance = Diagonal(0.05, 0.02);
    odo.num_covariance = 9;
    lcm.publish("SLAMD_ODOMETRY", &odo);
    // Wait (up to 1 s) for the estimate of the new pose before sending the next one.
    for (int waited = 0; listener.latest_index < i + 1 && waited < 1000; waited += 10) {
      lcm.handleTimeout(10);
    }
  }
  slamd::loop_closure_t loop;
  loop.utime = Now();
  loop.robot_a = "demo";
  loop.pose_a = 20;
  loop.robot_b = "demo";
  loop.pose_b = 0;
  loop.dimension = slamd::loop_closure_t::DIMENSION_2D;
  loop.values = {0.0, 0.0, 0.0};
  loop.num_values = 3;
  loop.covariance = Diagonal(0.02, 0.01);
  loop.num_covariance = 9;
  loop.robust_kernel = "";
  loop.robust_parameter = 0.0;
  lcm.publish("SLAMD_LOOP_CLOSURE", &loop);
  const std::int64_t before = listener.latest.update_sequence;
  for (int waited = 0; listener.latest.update_sequence == before && waited < 2000; waited += 10) {
    lcm.handleTimeout(10);
  }
  if (listener.latest_index != 20) {
    std::fprintf(stderr, "no estimate of pose 20 from slamd (is it running on this URL?)\n");
    return 1;
  }
  const auto& v = listener.latest.values;
  std::printf("pose 20 after the loop closure: x %.3f m, y %.3f m, theta %.3f rad", v[0], v[1],
              v[2]);
  if (listener.latest.num_covariance == 9) {
    std::printf(", sigma x %.3f m", std::sqrt(listener.latest.covariance[0]));
  }
  std::printf("\n");
  return listener.rejects == 0 ? 0 : 1;
}
