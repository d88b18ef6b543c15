// What a message spec is. Every inbound LCM type has one header here, server/messages/<type>.h,
// declaring its value in core types, Validate / Convert / ToLcm overloads for its LCM class, and
// a spec struct the rest of the server reads instead of switching on types:
//
//   struct OdometrySpec {
//     using Lcm = slamd::odometry_t;        // the generated LCM class
//     using Value = OdometryMeasurement;    // what Convert makes of it
//     static constexpr const char* kType = "odometry_t";    // the LCM type name (journal, rejects)
//     static constexpr const char* kChannel = "ODOMETRY";   // channel, after the prefix
//     static constexpr MessageRole kRole = ...;             // how the estimator treats it
//     static const std::string& Robot(const Lcm& or const Value&);  // who it is about
//     // measurements: the identity letter (kIdentity), Factor(...) and
//     static Outcome Apply(const Value&, GraphBuilder&, Verdict*);
//   };
//
// server/messages/inbound.h lists the specs; that list is the only place that names them all.
// GraphBuilder is what a measurement's Apply may do to the graph: look up robots and variables,
// add poses, landmarks and factors. The estimator implements it over the batch it is staging,
// which the solver takes in one update (or none of it, on failure), so a spec never touches the
// solver.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <tuple>

#include "core/base/key.h"
#include "core/factors/factor.h"
#include "core/factors/robust_kernel.h"
#include "core/sfm/landmark_initialization.h"
#include "core/variables/variable.h"
#include "server/ingest/measurements.h"
#include "server/ingest/shard_map.h"
#include "server/ingest/validation.h"

namespace slamd::server {

// A measurement's identity for duplicates and removal: (its spec's kIdentity letter, first key,
// second key or 0, kind); loop closures with the smaller key first. Stored in snapshots.
using MeasurementId = std::tuple<char, core::Key, core::Key, int>;

// How the estimator treats a message type: measurements are applied (Apply), retractions remove
// an applied measurement, queries are answered by the daemon after the update of their batch.
enum class MessageRole { kMeasurement, kRetraction, kQuery };

// What applying a message did (see server/estimator/estimator.h).
enum class Outcome { kApplied, kHeld, kRejected, kAlreadyHeld };

// The estimator's configured policies a measurement follows (EstimatorParams).
struct MeasurementPolicy {
  // A robot whose first message is odometry gets its first pose at the origin, with an
  // isotropic prior of anchor_sigma (AnchorPolicy::kAnchorAtOrigin).
  bool anchor_at_origin = false;
  double anchor_sigma = 1e-3;
  // For loop closures that name no kernel.
  core::RobustKernel loop_closure_kernel;
  // When a landmark seen by cameras is determined (frame_observations.h).
  core::LandmarkInitializationParams landmark_initialization;
  // A feature of a landmark in the graph whose pixel is farther than this from the landmark's
  // projection at the current estimate is rejected as a wrong match [px].
  double max_landmark_error_px = 50.0;
  // Map shards: which robots are this slamd's (server/ingest/shard_map.h).
  ShardMap shards;
};

class CameraTable;     // server/messages/camera_info.h
class LandmarkTracks;  // server/messages/landmark_tracks.h

class GraphBuilder {
 public:
  virtual ~GraphBuilder() = default;

  virtual const MeasurementPolicy& policy() const = 0;
  // A robot's key id (core::MakeKey's robot); nullopt when it has none yet.
  virtual std::optional<std::uint8_t> FindRobot(const std::string& name) const = 0;
  // The same, registering the robot on first sight; nullopt when 255 robots are registered.
  virtual std::optional<std::uint8_t> FindOrAddRobot(const std::string& name) = 0;
  // The robot has a pose in the graph or staged.
  virtual bool Anchored(std::uint8_t robot) const = 0;
  // The variable is in the graph or staged; its current estimate or staged initial guess.
  virtual bool Known(core::Key key) const = 0;
  virtual core::Variable Estimate(core::Key key) const = 0;
  // A pose beyond its anchored robot's newest: one that may still come (its odometry delayed,
  // refused while the server was busy, or sent by another process than the message's).
  virtual bool Ahead(core::Key pose) const = 0;

  // Stages pose `index` of `robot` (a new key) at `value`; the robot is then anchored and this
  // message its latest.
  virtual void AddPose(std::uint8_t robot, std::uint64_t index, const core::Variable& value) = 0;
  // Stages a new non-pose variable (a landmark) at its initial guess.
  virtual void AddVariable(core::Key key, const core::Variable& value) = 0;
  // Stages a factor that is not a measurement (an origin anchor: never a duplicate, not
  // removable).
  virtual void AddFactor(core::FactorPtr factor) = 0;
  // Marks the identity of the measurement about to be added as seen in this batch (call before
  // staging its new variables); AddMeasured then stages its factor: kApplied; or, when that
  // identity has a factor already, kAlreadyHeld for the same measurement and kRejected
  // (kDuplicate; `what` names the message type) for a different one.
  virtual void FirstTime(const MeasurementId& id) = 0;
  virtual Outcome AddMeasured(core::FactorPtr factor, core::Key first, const char* what,
                              Verdict* verdict) = 0;
  // Stages the factor of the message FirstTime() just admitted in place of the factor that
  // identity has (removed in the same update; none: added): kApplied. For messages that
  // supersede the previous one of their identity (a shard's summary).
  virtual Outcome AddReplacing(core::FactorPtr factor, core::Key first) = 0;
  // Records this message as the robot's latest (its utime and receipt time in estimate_t).
  virtual void Touch(std::uint8_t robot) = 0;
  // The cameras (camera_info_t) and the observations of landmarks not determined yet
  // (frame_observations_t): what a spec changes there is undone with its batch.
  virtual CameraTable& cameras() = 0;
  virtual LandmarkTracks& tracks() = 0;
  // Rejects a part of the message being applied (a feature of a frame) while the rest goes on.
  virtual void RejectPart(Verdict verdict) = 0;
  // Map shards: the shared map's landmarks another shard holds (its latest summary's list).
  virtual void NoteShardLandmarks(const std::string& shard,
                                  const std::vector<std::uint64_t>& landmarks) = 0;
};

// "robot 'a' pose 3", for messages.
std::string PoseName(const std::string& robot, std::uint64_t index);
// A Pose2 measurement on a Pose2 variable, or a Pose3 one on a Pose3.
bool SamePoseType(const core::Variable& pose, const RelativePose& measured);

}  // namespace slamd::server
