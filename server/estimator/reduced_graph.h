// The reduced pose graph (Johannsson, Kaess, Fallon, Leonard, "Temporally scalable visual SLAM
// using a reduced pose graph", ICRA 2013): a robot driving through a mapped area adds no node.
// A new pose whose predicted estimate lies within EstimatorParams::ReducedGraph's distance and
// angle of a pose node already in the map becomes an alias instead: a pose held as
// anchor ∘ offset, the anchor a node, the offset the composed odometry from the anchor with its
// first-order covariance. Measurements on aliases are composed onto their anchors:
//   odometry or a loop closure between aliases a∘Za and b∘Zb measuring z is a between factor
//     on (a, b) measuring Za ∘ z ∘ Zb⁻¹ (nothing when a = b: the robot went round inside one
//     node's neighbourhood);
//   a landmark seen at p (a point in the pose's frame) from a∘Z is a relative point on (a, l)
//     measuring Z·p;
// with the composed covariances. A pair of variables gets one composed factor of each kind (a
// robust one apart), the first: later ones are left out, as they share the errors of their aliases'
// offsets with it (fused as independent, they made the map overconfident and biased), so driving
// the same loop for hours adds neither nodes nor factors. A loop closure from a robot's newest pose
// (an alias) to the map re-anchors it when that makes its offset more certain: the closure is then
// used twice (in the composed factor and as the new offset), the approximation the reduced pose
// graph makes so that a robot localised against the map does not drift.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "core/base/key.h"
#include "core/factors/factor.h"
#include "core/variables/variable.h"
#include "server/messages/message_spec.h"     // MeasurementId
#include "server/snapshot/estimator_state.h"  // PoseAlias

namespace slamd::server {

// A composed measurement: a relative pose or a point in its first key's frame, with covariance.
struct ComposedMeasurement {
  core::Variable measured;
  Eigen::MatrixXd covariance;
};

// a ∘ b for two poses of one kind.
core::Variable ComposePoses(const core::Variable& a, const core::Variable& b);
// A pose's position (Pose2: z = 0); nullopt for other kinds.
std::optional<Eigen::Vector3d> PositionOf(const core::Variable& v);

// The alias a node is of itself (identity offset, no uncertainty), of the kind of `like`.
PoseAlias NodeAlias(core::Key node, const core::Variable& like);
// The pose `from` ∘ z given from's alias and z's covariance.
PoseAlias ComposeAlias(const PoseAlias& from, const ComposedMeasurement& z);
// The relative pose z between from and to (to = from ∘ z) as a measurement between their
// anchors: from.offset ∘ z ∘ to.offset⁻¹.
ComposedMeasurement ComposeBetween(const PoseAlias& from, const ComposedMeasurement& z,
                                   const PoseAlias& to);
// The alias of `pose` held relative to the node `anchor` (offset anchor⁻¹ ∘ pose) given their
// estimates and joint marginal covariance (blocks anchor then pose, each in its estimate's
// tangent): the offset's covariance is the relative pose's, not the sum of their marginals'.
PoseAlias RelativeAlias(core::Key anchor, const core::Variable& anchor_pose,
                        const core::Variable& pose, const Eigen::MatrixXd& joint);
// A relative point factor (a landmark seen as a point in the pose's frame).
bool IsRelativePoint(const core::Factor& f);
// Whether a measurement naming an alias is composed onto its anchor: a relative pose (odometry,
// loop closure) or a relative point; other kinds need the pose as a node.
bool Composable(const core::Factor& f);
// The inverse relative pose, with its covariance.
ComposedMeasurement InverseRelative(const ComposedMeasurement& z);
// A point p seen from the alias, in its anchor's frame: offset · p.
ComposedMeasurement ComposePoint(const PoseAlias& from, const ComposedMeasurement& p);

// Distance [m] and rotation angle [rad] between two poses of one kind.
struct PoseDistance {
  double distance = 0.0;
  double angle = 0.0;
};
PoseDistance DistanceBetween(const core::Variable& a, const core::Variable& b);

// Keys by grid cell of a position: the pose nodes near a place.
class NodeGrid {
 public:
  void Reset(double cell);
  void Add(core::Key key, const Eigen::Vector3d& at);
  // Calls near(key) for the keys of the cells within `radius` of `at`, until one returns true.
  template <typename F>
  bool Any(const Eigen::Vector3d& at, double radius, F&& near) const {
    const std::array<long, 3> c = Cell(at);
    const long reach = Reach(radius);
    for (long dx = -reach; dx <= reach; ++dx) {
      for (long dy = -reach; dy <= reach; ++dy) {
        for (long dz = -reach; dz <= reach; ++dz) {
          const auto it = cells_.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells_.end()) continue;
          for (core::Key key : it->second) {
            if (near(key)) return true;
          }
        }
      }
    }
    return false;
  }

 private:
  std::array<long, 3> Cell(const Eigen::Vector3d& at) const;
  long Reach(double radius) const;

  double cell_ = 1.0;
  std::map<std::array<long, 3>, std::vector<core::Key>> cells_;
};

// What the estimator keeps between updates: the aliases, the measurements merged (their
// identity and core::MeasurementDigest, for duplicates: a lifelong run merges hundreds of
// thousands, too many to keep as factors; listed by the alias they are forgotten with), and the
// nodes by place (positions as of when the grid was built, rebuilt every so many updates).
struct ReducedGraphState {
  std::map<core::Key, PoseAlias> aliases;
  std::map<MeasurementId, std::uint64_t> merged;
  std::map<core::Key, std::vector<MeasurementId>> merged_by_pose;
  NodeGrid grid;
  std::int64_t grid_sequence = -1;  // the update sequence it was built at (-1: not yet)
};

// What one batch changes (committed with its update): a new pose its factor has yet to place
// (node or alias), the aliases it adds or changes (nullopt: made a node), and the measurements
// it merged.
struct ReducedGraphStage {
  std::optional<std::pair<core::Key, core::Variable>> pending_pose;
  std::map<core::Key, std::optional<PoseAlias>> aliases;
  std::vector<std::pair<MeasurementId, core::FactorPtr>> merged;
  int left_out = 0;  // measurements merged without their information (AddComposed)
};

}  // namespace slamd::server
