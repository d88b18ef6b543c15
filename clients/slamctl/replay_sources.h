// What `slamctl replay` sends, as one ordered list of ReplayItems, from either source:
//
//  * datasets (one robot each) plus optional inter-robot closures: InterleaveRobots sends the
//    robots' steps round-robin (step 0 of every robot, then step 1, ...) and each inter-robot
//    loop_closure_t right after the step that makes both of its poses sent;
//  * an LCM event log (lcm-logger's format, detected by its magic number, whatever the file
//    name): ReadLcmLog keeps the events of slamd's inbound channels (<prefix>ODOMETRY,
//    LANDMARK, LOOP_CLOSURE, PRIOR, REMOVE_FACTOR) plus those whose channel fully matches an
//    optional extra regex, in log order, with their bytes unchanged.
//
// Inter-robot file, one closure per line ('#' starts a comment, blank lines skipped):
//   INTER_SE2 robotA idxA robotB idxB dx dy dθ  I11 I12 I13 I22 I23 I33
//   INTER_SE3 robotA idxA robotB idxB x y z qx qy qz qw  + 21 upper-triangular information
// Pose idxB of robotB in the frame of pose idxA of robotA; information in g2o order (the upper
// triangle row by row, (x, y, θ) / (t, R) order, slamd's tangent order); quaternion w last as in
// g2o. Errors name FILE:LINE.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "clients/slamctl/dataset_messages.h"
#include "core/base/status.h"
#include "server/transport/channels.h"

namespace slamd::clients {

// One message to publish, and what pacing and bookkeeping need to know about it.
struct ReplayItem {
  std::string channel;
  std::vector<std::uint8_t> bytes;
  std::string robot;  // the message's robot (robot_a for loop closures); "" when not known
  // The pose index this message gives the server for `robot` (its first odometry_t into that
  // pose, or a prior_t on a pose not seen before): an estimate_t with pose_index >= new_pose
  // acknowledges it. -1 when the message adds no pose.
  std::int64_t new_pose = -1;
  std::int64_t log_utime = 0;  // the event's log timestamp [µs] (logs only; 0 for datasets)
  // The message's own utime [µs], by which a reject_t names it (with channel and robot); 0 when
  // it did not decode.
  std::int64_t utime = 0;
};

struct RobotDataset {
  std::string robot;
  std::vector<StepMessages> steps;
};

struct InterRobotClosure {
  int line = 0;  // in its file, for messages
  slamd::loop_closure_t message;
};

// Parses an inter-robot closure file's text (`name` is used in messages only).
core::Result<std::vector<InterRobotClosure>> ParseInterRobot(const std::string& text,
                                                             const std::string& name);
core::Result<std::vector<InterRobotClosure>> ReadInterRobotFile(const std::string& path);

// Datasets (+ closures) -> items (see the file comment). InvalidArgument for a closure naming a
// robot that is not among `robots` or a pose no step of that robot introduces.
core::Result<std::vector<ReplayItem>> InterleaveRobots(
    const std::vector<RobotDataset>& robots, const std::vector<InterRobotClosure>& closures,
    const server::ChannelNames& channels);

// True when the file starts with an LCM event log's sync word (0xEDA1DA01, big-endian).
bool IsLcmLog(const std::string& path);

// The log's events to re-publish (see the file comment). `extra_channels` = "" keeps only the
// slamd channels. InvalidArgument for a malformed regex, IoError when the log cannot be read.
// Events of the slamd inbound types are decoded to fill robot / new_pose (bytes that do not
// decode are still sent, with robot ""; the server will reject them).
core::Result<std::vector<ReplayItem>> ReadLcmLog(const std::string& path,
                                                 const server::ChannelNames& channels,
                                                 const std::string& extra_channels);

}  // namespace slamd::clients
