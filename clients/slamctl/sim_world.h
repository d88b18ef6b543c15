// Synthetic SLAM worlds with ground truth, for `slamctl sim`, tests and benchmarks.
//
// A world is generated from SimParams alone: the same params (seed included) give the same world,
// bit for bit, on any platform with the same libm. Randomness is std::mt19937_64's raw output
// (standardised) with our own uniform and Box–Muller normal sampling, never the <random>
// distributions (their algorithms differ between standard libraries): sim_rng.h.
//
// Worlds (units: metres and radians; a pose maps body to world coordinates):
//   kManhattan  2D pose graph like Olson's M3500: the robot moves one metre per step on a unit
//               grid inside a square box, turning left/right at random (and at the walls; or on
//               a patrol route, SimParams::patrol). When it
//               enters a cell some earlier pose occupied (any robot), each such earlier pose gives
//               a loop closure with probability loop_probability (at most kMaxLoopsPerPose per
//               pose; the earliest poses first, on patrols the latest).
//   kLandmarks  the same robot motion plus point landmarks, uniform in the box; every pose observes
//               each landmark within sensor_range (bearing-range or relative-point). Landmarks no
//               pose observes are dropped; the rest are numbered 0.. in generation order.
//   kSphere     3D: rings of constant latitude on a sphere (like GTSAM's sphere2500), x forward
//               (east), z outward. Loop closures join a pose to the pose of the previous ring at
//               the same longitude (and, with several robots, to other robots' poses there).
//   kHelix      3D: turns of a helix climbing 1 m per turn, x along the direction of travel. Loop
//               closures join a pose to the pose one turn below (and other robots' poses).
//   Steps per ring/turn: round(sqrt(steps)), at least 4; at most 2 loop closures per pose. The
//   3D worlds are expressed in robot 0's first frame. With more robots than steps per ring, some
//   robots share a longitude offset (and so a trajectory).
//
// Several robots (robots > 1) share the world: each has its own start (Manhattan/landmarks: a
// random cell and heading; sphere/helix: a longitude offset of k/robots of a ring), its own
// odometry and loop closures, and loop closures with the other robots' earlier poses (inter-robot).
// Robot 0 starts at the identity pose in every world.
//
// Measurement model (what the factors of core/factors evaluate to at the truth):
//   Between pose measurements z with error e = z.LocalCoordinates(x_a⁻¹·x_b) are generated as
//   z = T·Pose2(n)⁻¹ (2D) or T·Exp(n)⁻¹ (3D), T the true relative pose, n ~ N(0, diag σ²) in
//   (x, y, θ) / (t, R) order, so that the error at the truth is exactly n.
//   Relative point: z = x.TransformTo(l) + n. Bearing-range: (b, r) of the true point plus
//   noise; the point r·(cos b, sin b) is what the datasets carry (no standard g2o or iSAM line for
//   bearing-range), with the first-order covariance J·diag(σb², σr²)·Jᵀ at the measured (b, r).
//   A sigma of 0 gives exact measurements on that axis; the noise model then uses kZeroSigmaFloor
//   so that information stays finite. noise_free keeps the sigmas for the information but adds no
//   noise at all.
//
// Outliers: round(outliers · number of loop closures) loop closures (intra- and inter-robot
// alike, picked at random) are replaced, in place, by a wrong one with the usual noise model: a
// uniformly random relative pose (translation in a cube of the world's size, any rotation)
// between a random pose pair. The later pose (robot_b, idx_b) is kept, so the edge still arrives
// when that pose does; the earlier one is drawn among the poses robot_a had by then (|a − b| > 1
// within a robot).
//
// Initial guesses (SimWorld::initial): each robot's odometry composed from its true start, and
// each landmark at its first observation by that robot seen from that guess: what a robot knows.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/base/status.h"
#include "core/factors/noise_model.h"
#include "core/factors/values.h"
#include "core/io/dataset.h"
#include "core/variables/variable.h"

namespace slamd::clients::sim {

enum class WorldKind { kManhattan, kLandmarks, kSphere, kHelix };
enum class ObservationKind { kBearingRange, kRelativePoint };

// "manhattan", "landmarks", "sphere", "helix" (and back; false for an unknown name).
const char* WorldKindName(WorldKind kind);
bool ParseWorldKind(const std::string& name, WorldKind* kind);

inline constexpr int kMaxLoopsPerPose = 3;       // 2D grid worlds
inline constexpr double kZeroSigmaFloor = 1e-4;  // sigma written for a zero-noise axis

struct SimParams {
  WorldKind world = WorldKind::kManhattan;
  std::uint64_t seed = 1;  // seeds std::mt19937_64
  int steps = 0;           // poses per robot (>= 2); 0 = the world's default (DefaultSteps)
  int robots = 1;          // >= 1
  double sigma_translation = 0.05;  // odometry/loop translation sigma per axis, m (>= 0)
  double sigma_rotation = 0.01;     // odometry/loop rotation sigma (3D: per axis), rad (>= 0)
  double loop_probability = 0.5;    // chance that a loop-closure candidate is kept, [0, 1]
  double outliers = 0.0;            // fraction of loop closures replaced by wrong ones, [0, 1]
  bool noise_free = false;          // add no noise (information still from the sigmas)
  // Grid worlds (manhattan, landmarks): side of the square in metres (1 m cells; >= 0); 0 = grown
  // with the poses so that the robots cover it about twice. Fixed, the robots revisit it for as
  // long as they drive (lifelong runs).
  int side = 0;
  // Grid worlds: steps of each robot's patrol route (>= 0). 0: the robots random-walk for as
  // long as they drive. Above 0: each robot random-walks this many steps, goes back to its
  // start along the grid (x first, then y), and from then on drives that closed route again
  // and again: a fleet that has mapped its area and keeps driving through it (lifelong runs).
  // A patrol's loop closures go to the latest earlier visits of a place (a front end matching
  // recent keyframes), a random walk's to the first ones.
  int patrol = 0;
  // Landmark worlds.
  int landmarks = 0;          // landmarks generated (>= 0); 0 = box area / 4
  double sensor_range = 3.0;  // m, > 0
  ObservationKind observation = ObservationKind::kBearingRange;
  double sigma_bearing = 0.01;  // rad (>= 0)
  double sigma_range = 0.05;    // m (>= 0)
  double sigma_point = 0.05;    // relative-point sigma per axis, m (>= 0)

  // Every range above; the message names the field ("SimParams::outliers = 1.5; violates <= 1").
  core::Status Validate() const;
};

int DefaultSteps(WorldKind kind);

// A pose-pose measurement: pose idx_b of robot_b seen from pose idx_a of robot_a.
struct SimEdge {
  enum class Kind { kOdometry, kLoop, kInterRobot };
  Kind kind = Kind::kOdometry;
  int robot_a = 0, idx_a = 0, robot_b = 0, idx_b = 0;
  core::Variable measured;  // Pose2 or Pose3
  core::NoiseModel noise = core::NoiseModel::Unit(3);
  bool outlier = false;  // replaced by a random wrong measurement
};

// Landmark `landmark` seen from pose `idx` of `robot`.
struct SimObservation {
  int robot = 0, idx = 0, landmark = 0;
  core::Point2 point = core::Point2::Zero();  // measured point in the pose frame (the dataset's)
  double bearing = 0.0, range = 0.0;          // measured (bearing-range worlds only)
  core::NoiseModel noise = core::NoiseModel::Unit(2);  // of `point`
};

struct SimWorld {
  SimParams params;  // as given, with steps and landmarks resolved to the actual counts
  bool is_3d = false;
  std::vector<std::vector<core::Variable>> truth;    // [robot][idx]: Pose2 or Pose3
  std::vector<std::vector<core::Variable>> initial;  // [robot][idx]: odometry composition
  std::vector<core::Point2> landmarks;               // true landmark positions
  // Generation (time) order: at each step, robot by robot, the odometry edge into the new pose,
  // then its loop closures (intra and inter), then its observations.
  std::vector<SimEdge> edges;
  std::vector<SimObservation> observations;
};

// Validates `params` and generates the world.
core::Result<SimWorld> Generate(const SimParams& params);

// The dataset of one robot as the readers would return it: keys 'x' idx (local, from 0) and
// 'l' landmark id; its odometry, intra-robot loop closures and observations in generation order
// (no inter-robot edges, no prior); initial = the robot's odometry guess and first-observation
// landmarks. `factor_of_edge`, when given, receives for each world edge its factor index in the
// graph (-1 for edges of other robots and inter-robot edges).
core::Dataset RobotDataset(const SimWorld& world, int robot,
                           std::vector<int>* factor_of_edge = nullptr);
// The true values of the same keys (poses, then the landmarks the robot observes).
core::Values RobotTruth(const SimWorld& world, int robot);

// Writes the world into directory `dir` (which must exist) and appends the file names to
// `written`. One robot: world.g2o, world_groundtruth.g2o, outliers.txt, and for landmark worlds
// world.isam (plus world_bearing_range.txt for bearing-range). Several robots: robot<k>.g2o,
// robot<k>_groundtruth.g2o (robot<k>.isam, robot<k>_bearing_range.txt), inter_robot.txt,
// outliers.txt. Formats are documented in the files' '#' headers and in sim.cc's help text.
// (Implemented in sim_world_io.cc.)
core::Status WriteWorld(const SimWorld& world, const std::string& dir,
                        std::vector<std::string>* written);

}  // namespace slamd::clients::sim
