// A Dataset as an ordered stream of incremental steps, one per pose in ascending id: what an
// incremental solver (or the server replaying a dataset) is fed, step by step.
//
// Step k introduces pose k (dataset.poses[k]) and carries:
//  * every factor whose newest pose is this one: a pose-pose factor goes to the step of its
//    later pose (in dataset.poses order), a pose-landmark factor to the step of its pose, in
//    graph order within the step. A factor on landmarks only goes to the step that introduces
//    the last of them. Every factor of the dataset is in exactly one step.
//  * the landmarks first seen in this step (by the first factor, in stream order, that touches
//    them), initialised from that observation and the dataset's initial guess of the observing
//    pose (RelativePointFactor: pose.TransformFrom(measured); BearingRangeFactor: the point at
//    that bearing and range); other factor types, and landmarks no pose factor touches (placed
//    in the last step), take dataset.initial's value. File vertices of landmarks (g2o
//    VERTEX_XY) are therefore not used, as an online system would not have them.
//  * the odometry: a BetweenFactor of this step from an earlier pose, preferring the previous
//    step's pose, else the latest earlier pose (ties: the first in graph order). A consumer can
//    predict the new pose from its current estimate of odometry_from with PredictPose().
//
// Poses with no factor (an isolated vertex) still get a step, with no factors and no odometry.
// Requires a consistent Dataset (as ReadDataset makes): every key of every factor is in
// dataset.poses or dataset.initial (checked: a violation aborts, as it is a programming error).
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include "core/factors/factor.h"
#include "core/factors/factor_graph.h"
#include "core/io/dataset.h"

namespace slamd::core {

struct DatasetStep {
  Key pose = 0;      // the pose this step introduces
  Variable initial;  // its initial guess (dataset.initial): a Pose2 or a Pose3
  // Landmarks first observed in this step, with their initial guess (see the file comment).
  std::vector<std::pair<Key, Variable>> new_landmarks;
  // The factors whose newest variable is introduced by this step, in graph order.
  std::vector<FactorPtr> factors;
  // A pose from an earlier step tied to `pose` by `odometry`, or 0 (never a pose key: pose keys
  // have symbol 'x') when there is none, e.g. for the first pose.
  Key odometry_from = 0;
  // The BetweenFactor (Pose2 or Pose3) between odometry_from and pose, or null. It may be
  // written either way round (keys()[0] is `pose` for a reversed edge, as in w100.graph).
  FactorPtr odometry;
};

// The steps of `dataset` held as indices into it (~12 bytes a pose; a DatasetStep holds its
// factors and guesses, ~230) and made one at a time, for a consumer that walks a long stream
// once (slamctl bench, whose memory per variable is compared with other solvers').
class IncrementalSteps {
 public:
  // Keeps a pointer to `dataset`, which must outlive it.
  explicit IncrementalSteps(const Dataset& dataset);
  int size() const { return static_cast<int>(odometry_.size()); }
  DatasetStep Step(int k) const;  // 0 <= k < size()

 private:
  const Dataset* dataset_;
  // Step k's factors, by index into dataset.graph: factors_[factor_begin_[k] ..
  // factor_begin_[k + 1]); its new landmarks likewise.
  std::vector<int> factor_begin_, factors_;
  std::vector<int> landmark_begin_;
  std::vector<std::pair<Key, Variable>> landmarks_;
  std::vector<int> odometry_;  // per step: index into dataset.graph, or -1
};

// The steps of `dataset`, one per pose, in the order of dataset.poses (ascending id).
std::vector<DatasetStep> MakeIncrementalSteps(const Dataset& dataset);

// The pose predicted for step.pose from a value of step.odometry_from:
// from ∘ z when the factor is written (from, pose), from ∘ z⁻¹ when written (pose, from).
// step.odometry must be set and `from` must have its pose type (checked).
Variable PredictPose(const DatasetStep& step, const Variable& from);

// The input an incremental solver gets for `step` (the protocol slamctl bench and replay use):
// the step's factors, the new pose predicted through its odometry from estimate(odometry_from)
// (the dataset's guess when the step has no odometry), and each new landmark placed by its first
// observation in the step, from the predicted pose or estimate(observer) for an earlier pose
// (the stream's guess when no factor of the step places it). `estimate` returns the current
// estimate of an earlier variable. Appends to *factors and inserts into *values.
void PrepareStep(const DatasetStep& step, const std::function<Variable(Key)>& estimate,
                 FactorGraph* factors, Values* values);

}  // namespace slamd::core
