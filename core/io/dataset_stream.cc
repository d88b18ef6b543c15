#include "core/io/dataset_stream.h"

#include <algorithm>
#include <optional>
#include <unordered_map>

#include "core/factors/factor.h"

namespace slamd::core {
namespace {

// The landmark `key`'s first guess from `factor`, its first observation (see the header).
Variable InitialLandmark(const Dataset& dataset, const Factor& factor, Key key) {
  const KeyVector& keys = factor.keys();
  if (keys.size() == 2 && keys[1] == key) {
    const std::optional<Variable> v = factor.Predict(0, dataset.initial.Get(keys[0]));
    if (v) return *v;
  }
  return dataset.initial.Get(key);  // checked: aborts if the dataset has no value for it
}

// Chooses step.odometry among the BetweenFactors of the step (see the header).
void ChooseOdometry(const std::unordered_map<Key, int>& step_of_pose, Key previous,
                    DatasetStep* step) {
  int best_step = -1;
  for (const FactorPtr& factor : step->factors) {
    if (!MeasuredRelativePose(*factor)) continue;
    const KeyVector& keys = factor->keys();
    const Key other = keys[0] == step->pose ? keys[1] : keys[0];
    const auto it = step_of_pose.find(other);
    if (other == step->pose || it == step_of_pose.end()) continue;  // not between two poses
    const int other_step = it->second;
    if (other == previous) {
      step->odometry_from = other;
      step->odometry = factor;
      return;
    }
    if (other_step > best_step) {
      best_step = other_step;
      step->odometry_from = other;
      step->odometry = factor;
    }
  }
}

}  // namespace

std::vector<DatasetStep> MakeIncrementalSteps(const Dataset& dataset) {
  const int n = static_cast<int>(dataset.poses.size());
  if (n == 0) return {};
  std::vector<DatasetStep> steps(n);
  std::unordered_map<Key, int> step_of_pose;
  for (int k = 0; k < n; ++k) {
    steps[k].pose = dataset.poses[k];
    steps[k].initial = dataset.initial.Get(dataset.poses[k]);
    step_of_pose[dataset.poses[k]] = k;
  }

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
  std::unordered_map<Key, int> step_of_landmark;
  const auto introduce = [&](Key key, int step, const Variable& value) {
    if (step_of_landmark.emplace(key, step).second) {
      steps[step].new_landmarks.emplace_back(key, value);
    }
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
  for (int k = 0; k < n; ++k) {
    std::sort(bucket[k].begin(), bucket[k].end());
    for (const int i : bucket[k]) steps[k].factors.push_back(graph[i]);
    ChooseOdometry(step_of_pose, k > 0 ? dataset.poses[k - 1] : 0, &steps[k]);
  }
  return steps;
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
