// A dataset as the ordered LCM messages one robot would send to slamd (what `slamctl replay`
// publishes): one group per core::DatasetStep of core::MakeIncrementalSteps, in step order.
//
//   step 0        prior_t on the first pose at its initial value (isotropic sigma
//                 `anchor_sigma`, as `slamctl bench --solver isam2` anchors it), unless
//                 anchor_sigma is 0; then the step's factors as below.
//   step k        odometry_t for step.odometry, first; then the step's other factors in graph
//                 order:
//                   BetweenFactor<Pose2/Pose3>                 -> loop_closure_t (same robot twice)
//                   BearingRangeFactor                         -> landmark_observation_t
//                                                                 KIND_BEARING_RANGE_2D
//                   RelativePointFactor<Pose2,Point2 / Pose3,Point3>
//                                                              -> KIND_RELATIVE_POINT_2D / _3D
//
// Values and covariances are the factors' measured values and noise covariances (Ω⁻¹), written
// by server/ingest ToLcm, so server::Convert() of a message gives back the factor's
// measurement. Odometry written backwards in the dataset (keys()[0] is the step's new pose, as
// in w100.graph) is sent forwards: z⁻¹ with covariance H Σ Hᵀ, H the Jacobian of the inverse
// (first order; slamd's odometry_t must go from a known pose to the new one). Loop closures keep
// the dataset's direction. Robust kernels of between factors are kept.
//
// Pose indices and landmark ids are the dataset's ids (KeyIndex); landmark ids in the robot's
// namespace, or in the map namespace all robots share (shared_landmarks: datasets of several
// robots that number one world's landmarks alike, as `slamctl sim` writes them).
// utime of step k's messages = utime_start_us + k * utime_step_us (deterministic, so the same
// dataset always gives the same bytes).
// Errors: InvalidArgument for a factor type with no message form (the message names it and its
// step) or a bad option; the dataset must be one ReadDataset made.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "core/base/status.h"
#include "core/io/dataset.h"
#include "server/transport/channels.h"
#include "slamd/camera_info_t.hpp"
#include "slamd/frame_observations_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"

namespace slamd::clients {

// One inbound message of slamd.
using RobotMessage =
    std::variant<slamd::prior_t, slamd::odometry_t, slamd::loop_closure_t,
                 slamd::landmark_observation_t, slamd::camera_info_t, slamd::frame_observations_t>;

struct DatasetMessageOptions {
  // Robot name: 1..64 chars of [A-Za-z0-9_.-] (checked).
  std::string robot = "robot";
  // Sigma of the anchoring prior on the first pose [m, rad]; 0 = send no prior (the server then
  // holds the robot until something connects it, or anchors it at the origin if so configured).
  double anchor_sigma = 1e-3;
  std::int64_t utime_start_us = 0;    // utime of step 0's messages [µs], >= 0
  std::int64_t utime_step_us = 1000;  // utime increment per step [µs], >= 0
  bool shared_landmarks = false;      // landmark ids name the shared map's landmarks
};

struct StepMessages {
  std::uint64_t pose_index = 0;  // the pose this step introduces (dataset id)
  // The step gives the server its pose (anchoring prior or odometry), so an estimate_t for
  // pose_index will follow. False for an isolated pose (no odometry, not the first step).
  bool introduces_pose = false;
  std::vector<RobotMessage> messages;  // in sending order
};

core::Result<std::vector<StepMessages>> MakeDatasetMessages(const core::Dataset& dataset,
                                                            const DatasetMessageOptions& options);

// The total number of messages in `steps`.
std::size_t CountMessages(const std::vector<StepMessages>& steps);

// The channel of `message` (its spec's, server/messages/inbound.h).
std::string ChannelOf(const RobotMessage& message, const server::ChannelNames& channels);
// The LCM encoding of `message`.
core::Status EncodeMessage(const RobotMessage& message, std::vector<std::uint8_t>* bytes);

// True when `name` is a valid robot name (1..64 chars of [A-Za-z0-9_.-]).
bool IsValidRobotName(const std::string& name);

}  // namespace slamd::clients
