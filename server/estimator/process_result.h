// What Estimator::Process reports for a batch: the measurements that took effect, those
// rejected (with a Verdict naming why), and the solver updates that ran.
#pragma once

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/isam/isam2.h"
#include "server/messages/inbound.h"

namespace slamd::server {

struct Rejection {
  Inbound message;
  Verdict verdict;
};

struct ProcessResult {
  core::Status status;  // of the first failed Isam2 update (ok when none failed)
  int applied = 0;      // measurements and retractions that took effect
  // When each of them was received (Inbound::received_us), for the ingest-to-publish latency of
  // every message, not only the newest of a robot.
  std::vector<std::int64_t> applied_received_us;
  std::vector<Rejection> rejections;
  // Robots of the messages that were already held (the same measurement applied before): the
  // daemon acknowledges them with these robots' estimates.
  std::set<std::string> already_held_robots;
  std::vector<core::Isam2Result> updates;  // every Isam2::Update that ran, in order
};

}  // namespace slamd::server
