// Internal to `slamctl replay`: its options, and the runner (replay_run.cc) that publishes the
// items, paces them, waits for the server to settle and prints the summary.
#pragma once

#include <set>
#include <string>
#include <vector>

#include "clients/slamctl/client_common.h"
#include "clients/slamctl/replay_sources.h"

namespace slamd::clients::replay {

enum class Pacing {
  kFast,      // window of unacknowledged poses per robot (default for datasets)
  kRate,      // poses per second
  kSpeed,     // log timestamps scaled (default for logs, speed 1)
  kLockstep,  // wait for the estimate of each pose before the next
};

struct ReplayOptions {
  std::vector<std::string> sources;
  std::vector<std::string> robots;  // --robot, one per dataset
  std::string inter_robot;
  std::string stereo;          // --stereo: a reconstruction's stereo.txt (slamctl sim --stereo)
  std::string channels_regex;  // --channels: extra log channels to re-publish
  Pacing pacing = Pacing::kFast;
  double rate_hz = 0.0;
  double speed = 1.0;
  bool speed_given = false;
  bool fast = false;
  bool lockstep = false;
  int window = 100;
  double settle_timeout_s = 30.0;
  double ack_timeout_s = 10.0;  // --lockstep / --fast: longest wait for an estimate
  double wait_server_s = 2.0;   // wait for a first status_t before sending
  double resend_for_s = 60.0;   // a message refused as queue_full goes again (replay_resend.h)
  double anchor_sigma = 1e-3;
  std::string isam_noise = "sqrt-information";
  bool shared_landmarks = false;  // --shared-landmarks: datasets' landmark ids name one map
  bool json = false;
  bool quiet = false;
  ConnectionOptions connection;
};

// Publishes `items` to the server as the options say and prints the summary; ends the command
// with its exit code (CommandExit) on failure. `robots`: whose reject_t count as ours.
int Run(const ReplayOptions& options, const std::vector<ReplayItem>& items,
        const std::set<std::string>& robots);

}  // namespace slamd::clients::replay
