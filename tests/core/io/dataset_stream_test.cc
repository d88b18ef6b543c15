// MakeIncrementalSteps: every factor in exactly one step, nothing used before it is introduced,
// odometry and landmark initialisation; on every development dataset, with victoriaPark's
// non-contiguous ids and w100's reversed edges looked at closely.
#include "core/io/dataset_stream.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "tests/testing/datasets.h"
#include "tests/testing/read_dataset.h"

namespace slamd::core {
namespace {

using slamd::testing::SharedDatasetPath;
using slamd::testing::TestDataPath;

using testing::MustReadDataset;

bool IsBetween(const Factor& f) {
  return dynamic_cast<const BetweenFactor<Pose2>*>(&f) ||
         dynamic_cast<const BetweenFactor<Pose3>*>(&f);
}

// The contract of dataset_stream.h, checked from scratch.
void ExpectStreamInvariants(const Dataset& d, const std::vector<DatasetStep>& steps) {
  ASSERT_EQ(steps.size(), d.poses.size());
  std::map<const Factor*, int> graph_index;
  for (std::size_t i = 0; i < d.graph.size(); ++i)
    graph_index[d.graph[i].get()] = static_cast<int>(i);
  std::map<Key, int> pose_step, landmark_step;
  for (int k = 0; k < static_cast<int>(steps.size()); ++k) pose_step[d.poses[k]] = k;

  std::map<const Factor*, int> seen;
  for (int k = 0; k < static_cast<int>(steps.size()); ++k) {
    const DatasetStep& step = steps[k];
    ASSERT_EQ(step.pose, d.poses[k]);
    ASSERT_EQ(step.initial.index(), d.initial.Get(step.pose).index());
    ASSERT_LE(LocalCoordinates(step.initial, d.initial.Get(step.pose)).norm(), 1e-14);
    for (const auto& [key, value] : step.new_landmarks) {
      ASSERT_EQ(pose_step.count(key), 0u);
      ASSERT_TRUE(landmark_step.emplace(key, k).second) << "introduced twice: " << KeyToString(key);
      ASSERT_TRUE(AllFinite(value));
    }
    int previous_index = -1;
    bool has_between_to_previous = false;
    for (const FactorPtr& f : step.factors) {
      ASSERT_EQ(graph_index.count(f.get()), 1u);
      const int index = graph_index[f.get()];
      ASSERT_GT(index, previous_index) << "not in graph order";
      previous_index = index;
      ++seen[f.get()];
      int newest_pose = -1;
      for (const Key key : f->keys()) {
        if (pose_step.count(key)) {
          newest_pose = std::max(newest_pose, pose_step[key]);
        } else {
          ASSERT_TRUE(landmark_step.count(key)) << KeyToString(key) << " used before introduced";
          ASSERT_LE(landmark_step[key], k);
        }
      }
      if (newest_pose >= 0) {
        ASSERT_EQ(newest_pose, k) << "factor " << index;
      }
      if (IsBetween(*f) && k > 0 &&
          (f->keys()[0] == d.poses[k - 1] || f->keys()[1] == d.poses[k - 1])) {
        has_between_to_previous = true;
      }
    }
    if (step.odometry) {
      ASSERT_TRUE(IsBetween(*step.odometry));
      ASSERT_EQ(graph_index.count(step.odometry.get()), 1u);
      ASSERT_TRUE(std::find(step.factors.begin(), step.factors.end(), step.odometry) !=
                  step.factors.end());
      const std::span<const Key> keys = step.odometry->keys();
      ASSERT_TRUE((keys[0] == step.pose && keys[1] == step.odometry_from) ||
                  (keys[1] == step.pose && keys[0] == step.odometry_from));
      ASSERT_LT(pose_step.at(step.odometry_from), k);
      if (has_between_to_previous) {
        ASSERT_EQ(step.odometry_from, d.poses[k - 1]);
      }
      // The prediction from the dataset's guess of odometry_from satisfies the measurement.
      Values values;
      ASSERT_TRUE(values.Insert(step.odometry_from, d.initial.Get(step.odometry_from)).ok());
      ASSERT_TRUE(
          values.Insert(step.pose, PredictPose(step, d.initial.Get(step.odometry_from))).ok());
      ASSERT_LT(step.odometry->Error(values).norm(), 1e-9) << KeyToString(step.pose);
    } else {
      ASSERT_EQ(step.odometry_from, 0u);
      ASSERT_FALSE(has_between_to_previous);
    }
  }
  // Every factor exactly once; every landmark exactly once.
  ASSERT_EQ(seen.size(), d.graph.size());
  for (const auto& [f, count] : seen) ASSERT_EQ(count, 1) << graph_index[f];
  ASSERT_EQ(landmark_step.size(), d.landmarks.size());
}

class SharedStreamTest : public ::testing::TestWithParam<const char*> {};

TEST_P(SharedStreamTest, Invariants) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath(GetParam()));
  const Dataset d = MustReadDataset(SharedDatasetPath(GetParam()));
  ExpectStreamInvariants(d, MakeIncrementalSteps(d));
}

INSTANTIATE_TEST_SUITE_P(AllFiles, SharedStreamTest,
                         ::testing::Values("manhattan.g2o", "manhattanOlson3500.txt", "intel.g2o",
                                           "input_INTEL_g2o.g2o", "parking-garage.g2o",
                                           "pose2example.txt", "pose3example.txt"),
                         [](const auto& info) {
                           std::string name = info.param;
                           for (char& ch : name) {
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           }
                           return name;
                         });

TEST(DatasetStream, VictoriaParkNonContiguousIds) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("victoriaPark.txt"));
  const Dataset d = MustReadDataset(SharedDatasetPath("victoriaPark.txt"));
  const std::vector<DatasetStep> steps = MakeIncrementalSteps(d);
  ExpectStreamInvariants(d, steps);
  // Odometry always comes from the previous step's pose, even across id gaps (4 -> 6, 8 -> 10).
  for (std::size_t k = 1; k < steps.size(); ++k) {
    ASSERT_EQ(steps[k].odometry_from, steps[k - 1].pose) << k;
    ASSERT_TRUE(
        LocalCoordinates(PredictPose(steps[k], steps[k - 1].initial), steps[k].initial).norm() <
        1e-12);
  }
  EXPECT_EQ(steps[5].pose, MakeKey('x', 6));
  EXPECT_EQ(steps[5].odometry_from, MakeKey('x', 4));
  // Landmark 5 is first seen from x4 (file line 5), so in step 4, where the file also puts it.
  ASSERT_EQ(steps[4].new_landmarks.size(), 1u);
  EXPECT_EQ(steps[4].new_landmarks[0].first, MakeKey('l', 5));
  std::size_t introduced = 0;
  for (const DatasetStep& step : steps) {
    for (const auto& [key, value] : step.new_landmarks) {
      ++introduced;
      ASSERT_LT(LocalCoordinates(value, d.initial.Get(key)).norm(), 1e-12) << KeyToString(key);
    }
  }
  EXPECT_EQ(introduced, 151u);
}

TEST(DatasetStream, W100ReversedEdges) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("w100.graph"));
  const Dataset d = MustReadDataset(SharedDatasetPath("w100.graph"));
  const std::vector<DatasetStep> steps = MakeIncrementalSteps(d);
  ExpectStreamInvariants(d, steps);
  EXPECT_EQ(steps[0].odometry, nullptr);
  for (std::size_t k = 1; k < steps.size(); ++k) {
    ASSERT_NE(steps[k].odometry, nullptr) << k;
    EXPECT_EQ(steps[k].odometry_from, steps[k - 1].pose);
    EXPECT_EQ(steps[k].odometry->keys()[0], steps[k].pose);  // written reversed: "EDGE2 k k-1"
  }
  // EQUIV 21 1 belongs to x21's step.
  const FactorPtr& equiv = d.graph[300];
  EXPECT_TRUE(std::find(steps[21].factors.begin(), steps[21].factors.end(), equiv) !=
              steps[21].factors.end());
}

TEST(DatasetStream, SmallFileStepByStep) {
  const Dataset d = MustReadDataset(TestDataPath("small_slam2d.g2o"));
  const std::vector<DatasetStep> steps = MakeIncrementalSteps(d);
  ExpectStreamInvariants(d, steps);
  ASSERT_EQ(steps.size(), 5u);
  const auto graph = [&](std::initializer_list<int> indices) {
    std::vector<FactorPtr> out;
    for (const int i : indices) out.push_back(d.graph[i]);
    return out;
  };
  // x0: l0 from its observation (1.4, 2.1), not from its vertex (1.5, 2.0).
  EXPECT_EQ(steps[0].factors, graph({2}));
  ASSERT_EQ(steps[0].new_landmarks.size(), 1u);
  EXPECT_EQ(steps[0].new_landmarks[0].first, MakeKey('l', 0));
  EXPECT_TRUE(std::get<Point2>(steps[0].new_landmarks[0].second).isApprox(Point2(1.4, 2.1), 1e-15));
  EXPECT_EQ(steps[0].odometry_from, 0u);
  EXPECT_EQ(steps[1].factors, graph({0}));
  EXPECT_EQ(steps[2].factors, graph({1, 3}));
  ASSERT_EQ(steps[2].new_landmarks.size(), 1u);
  EXPECT_EQ(steps[2].new_landmarks[0].first, MakeKey('l', 7));
  EXPECT_EQ(steps[3].factors, graph({4, 6}));
  EXPECT_EQ(steps[3].odometry, d.graph[4]);
  EXPECT_EQ(steps[4].pose, MakeKey('x', 5));
  EXPECT_EQ(steps[4].factors, graph({5, 7}));
  EXPECT_EQ(steps[4].odometry, d.graph[5]);  // "EDGE_SE2 5 3": reversed
  EXPECT_EQ(steps[4].odometry_from, MakeKey('x', 3));
  EXPECT_TRUE(steps[4].new_landmarks.empty());
}

TEST(DatasetStream, LandmarkOnlyFactorsAndUnobservedLandmarks) {
  Dataset d = MustReadDataset(TestDataPath("small_slam2d.g2o"));
  const Key l7 = MakeKey('l', 7), l9 = MakeKey('l', 9);
  d.graph.Emplace<PriorFactor<Point2>>(l7, Point2(0, 0), NoiseModel::Unit(2));  // factor 8
  ASSERT_TRUE(d.initial.Insert(l9, Point2(4, 4)).ok());
  d.landmarks.push_back(l9);
  d.graph.Emplace<PriorFactor<Point2>>(l9, Point2(4, 4), NoiseModel::Unit(2));  // factor 9
  const std::vector<DatasetStep> steps = MakeIncrementalSteps(d);
  ExpectStreamInvariants(d, steps);
  EXPECT_EQ(steps[2].factors.back(), d.graph[8]);  // with l7's introduction
  EXPECT_EQ(steps[4].factors.back(), d.graph[9]);  // l9: last step
  ASSERT_EQ(steps[4].new_landmarks.size(), 1u);
  EXPECT_EQ(steps[4].new_landmarks[0].first, l9);
  EXPECT_TRUE(std::get<Point2>(steps[4].new_landmarks[0].second).isApprox(Point2(4, 4), 0.0));
}

TEST(DatasetStream, EmptyDatasetHasNoSteps) {
  EXPECT_TRUE(MakeIncrementalSteps(Dataset{}).empty());
  Dataset landmarks_only;  // nothing to put its landmark in
  ASSERT_TRUE(landmarks_only.initial.Insert(MakeKey('l', 0), Point2(1, 2)).ok());
  landmarks_only.landmarks.push_back(MakeKey('l', 0));
  EXPECT_EQ(IncrementalSteps(landmarks_only).size(), 0);
  EXPECT_TRUE(MakeIncrementalSteps(landmarks_only).empty());
}

// Made one at a time and in any order (slamctl bench makes them as it goes), the steps keep the
// contract, with the odometry and the landmarks of each.
TEST(DatasetStream, StepsMadeOneAtATimeInAnyOrder) {
  SLAMD_SKIP_IF_NO_SHARED_DATASET(SharedDatasetPath("victoriaPark.txt"));
  const Dataset d = MustReadDataset(SharedDatasetPath("victoriaPark.txt"));
  const IncrementalSteps lazy(d);
  ASSERT_EQ(lazy.size(), static_cast<int>(d.poses.size()));
  std::vector<DatasetStep> steps(lazy.size());
  for (int k = lazy.size() - 1; k >= 0; --k) steps[k] = lazy.Step(k);
  ExpectStreamInvariants(d, steps);
  EXPECT_EQ(lazy.Step(1).odometry_from, steps[0].pose);
  EXPECT_DEATH((void)lazy.Step(lazy.size()), "IncrementalSteps: step");
}

}  // namespace
}  // namespace slamd::core
