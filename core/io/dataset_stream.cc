#include "core/io/dataset_stream.h"

#include <algorithm>
#include <optional>
#include <span>
#include <unordered_map>

#include "core/factors/factor.h"

namespace slamd::core {
namespace {

// The landmark `key`'s first guess from `factor`, its first observation (see the header).
Variable InitialLandmark(const Dataset& dataset, const Factor& factor, Key key) {
  const std::span<const Key> keys = factor.keys();
  if (keys.size() == 2 && keys[1] == key) {
    const std::optional<Variable> v = factor.Predict(0, dataset.initial.Get(keys[0]));
    if (v) return *v;
  }
  return dataset.initial.Get(key);  // checked: aborts if the dataset has no value for it
}

// The odometry among the BetweenFactors `factors` (indices into graph) of the step of `pose`
// (see the header): an index into graph, or -1.
int ChooseOdometry(const FactorGraph& graph, std::span<const int> factors,
                   const std::unordered_map<Key, int>& step_of_pose, Key pose, Key previous) {
  int best = -1, best_step = -1;
  for (const int i : factors) {
    if (!MeasuredRelativePose(*graph[i])) continue;
    const std::span<const Key> keys = graph[i]->keys();
    const Key other = keys[0] == pose ? keys[1] : keys[0];
    const auto it = step_of_pose.find(other);
    if (other == pose || it == step_of_pose.end()) continue;  // not between two poses
    if (other == previous) return i;
    if (it->second > best_step) {
      best_step = it->second;
      best = i;
    }
  }
  return best;
}

}  // namespace

IncrementalSteps::IncrementalSteps(const Dataset& dataset) : dataset_(&dataset) {
  const int n = static_cast<int>(dataset.poses.size());
  if (n == 0) return;
  std::unordered_map<Key, int> step_of_pose;
  for (int k = 0; k < n; ++k) step_of_pose[dataset.poses[k]] = k;

  // 1. Factors with a pose go to the step of their latest pose; the others wait for step 3.
  const FactorGraph& graph = dataset.graph;
  std::vector<std::vector<int>> bucket(n);
  std::vector<int> landmark_only;
  for (int i = 0; i < static_cast<int>(graph.size()); ++i) {
    int step = -1;
    for (const Key key : graph[i]->keys()) {
      const auto it = step_of_pose.find(key);
      if (it != step_of_pose.end()) step = std::max(step, it->second);
    }
    if (step >= 0) {
      bucket[step].push_back(i);
    } else {
      landmark_only.push_back(i);
    }
  }

  // 2. Landmarks enter with the first factor (in stream order) that touches them.
  std::vector<std::vector<std::pair<Key, Variable>>> new_landmarks(n);
  std::unordered_map<Key, int> step_of_landmark;
  const auto introduce = [&](Key key, int step, const Variable& value) {
    if (step_of_landmark.emplace(key, step).second) new_landmarks[step].emplace_back(key, value);
  };
  for (int k = 0; k < n; ++k) {
    for (const int i : bucket[k]) {
      for (const Key key : graph[i]->keys()) {
        if (step_of_pose.count(key) == 0 && step_of_landmark.count(key) == 0) {
          introduce(key, k, InitialLandmark(dataset, *graph[i], key));
        }
      }
    }
  }

  // 3. Factors on landmarks only: the step of their last landmark (the last step for a landmark
  //    no pose factor touches). Then every remaining landmark, in the last step.
  for (const int i : landmark_only) {
    int step = 0;
    for (const Key key : graph[i]->keys()) {
      introduce(key, n - 1, dataset.initial.Get(key));
      step = std::max(step, step_of_landmark.at(key));
    }
    bucket[step].push_back(i);
  }
  for (const Key key : dataset.landmarks) {
    if (step_of_landmark.count(key) == 0) introduce(key, n - 1, dataset.initial.Get(key));
  }

  // 4. Factors in graph order, then the odometry of each step.
  factor_begin_.reserve(n + 1);
  factors_.reserve(graph.size());
  landmark_begin_.reserve(n + 1);
  odometry_.reserve(n);
  for (int k = 0; k < n; ++k) {
    std::sort(bucket[k].begin(), bucket[k].end());
    factor_begin_.push_back(static_cast<int>(factors_.size()));
    factors_.insert(factors_.end(), bucket[k].begin(), bucket[k].end());
    landmark_begin_.push_back(static_cast<int>(landmarks_.size()));
    landmarks_.insert(landmarks_.end(), new_landmarks[k].begin(), new_landmarks[k].end());
    odometry_.push_back(ChooseOdometry(graph, bucket[k], step_of_pose, dataset.poses[k],
                                       k > 0 ? dataset.poses[k - 1] : 0));
  }
  factor_begin_.push_back(static_cast<int>(factors_.size()));
  landmark_begin_.push_back(static_cast<int>(landmarks_.size()));
}

DatasetStep IncrementalSteps::Step(int k) const {
  SLAMD_CHECK(k >= 0 && k < size()) << "IncrementalSteps: step " << k << " of " << size();
  const FactorGraph& graph = dataset_->graph;
  DatasetStep step;
  step.pose = dataset_->poses[k];
  step.initial = dataset_->initial.Get(step.pose);
  step.new_landmarks.assign(landmarks_.begin() + landmark_begin_[k],
                            landmarks_.begin() + landmark_begin_[k + 1]);
  step.factors.reserve(factor_begin_[k + 1] - factor_begin_[k]);
  for (int i = factor_begin_[k]; i < factor_begin_[k + 1]; ++i) {
    step.factors.push_back(graph[factors_[i]]);
  }
  if (odometry_[k] >= 0) {
    step.odometry = graph[odometry_[k]];
    const std::span<const Key> keys = step.odometry->keys();
    step.odometry_from = keys[0] == step.pose ? keys[1] : keys[0];
  }
  return step;
}

std::vector<DatasetStep> MakeIncrementalSteps(const Dataset& dataset) {
  const IncrementalSteps steps(dataset);
  std::vector<DatasetStep> out;
  out.reserve(steps.size());
  for (int k = 0; k < steps.size(); ++k) out.push_back(steps.Step(k));
  return out;
}

Variable PredictPose(const DatasetStep& step, const Variable& from) {
  SLAMD_CHECK(step.odometry != nullptr)
      << "PredictPose: step of " << KeyToString(step.pose) << " has no odometry";
  const int known = step.odometry->keys()[0] == step.odometry_from ? 0 : 1;
  const std::optional<Variable> pose = step.odometry->Predict(known, from);
  SLAMD_CHECK(pose.has_value()) << "PredictPose: the odometry is a " << step.odometry->Name();
  return *pose;
}

}  // namespace slamd::core

namespace slamd::core {

void PrepareStep(const DatasetStep& step, const std::function<Variable(Key)>& estimate,
                 FactorGraph* factors, Values* values) {
  const Variable pose = step.odometry ? PredictPose(step, estimate(step.odometry_from)) : step.initial;
  SLAMD_CHECK(values->Insert(step.pose, pose).ok()) << "PrepareStep: " << KeyToString(step.pose);
  for (const auto& [key, fallback] : step.new_landmarks) {
    Variable guess = fallback;
    for (const FactorPtr& f : step.factors) {
      if (f->keys().size() != 2 || f->keys()[1] != key) continue;
      const Key observer = f->keys()[0];
      const Variable from = observer == step.pose ? pose : estimate(observer);
      if (std::optional<Variable> v = f->Predict(0, from)) {
        guess = *v;
        break;
      }
    }
    SLAMD_CHECK(values->Insert(key, guess).ok()) << "PrepareStep: " << KeyToString(key);
  }
  for (const FactorPtr& f : step.factors) factors->Add(f);
}

}  // namespace slamd::core
