// How Isam2 orders the re-eliminated top (Isam2Params::max_landmarks_last): a frame that sees
// many landmarks does not put them all in the root clique, a robot seeing few keeps them there,
// and either way every step settles at the batch optimum.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/batch/batch_solver.h"
#include "core/factors/between_factor.h"
#include "core/factors/prior_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/isam/isam2.h"
#include "tests/testing/solver_checks.h"

namespace slamd::core {
namespace {

struct Frame {
  FactorGraph factors;
  Values values;
};

// Poses along x, each seeing `points` points (3D, relative) spread in front of the track.
std::vector<Frame> VisualStream(int poses, int points, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto jitter = [&](double sigma) {
    return Vector3(sigma * noise(rng), sigma * noise(rng), sigma * noise(rng));
  };
  const NoiseModel odometry = NoiseModel::Isotropic(6, 0.05).value();
  const NoiseModel seen = NoiseModel::Isotropic(3, 0.1).value();
  std::vector<Point3> world;
  for (int j = 0; j < points; ++j) {
    world.emplace_back(0.5 * poses * (j % 10) / 10.0, -3.0 + 6.0 * (j / 10) / 3.0, 2.0);
  }
  std::vector<Frame> frames(poses);
  for (int i = 0; i < poses; ++i) {
    const Pose3 truth(Rot3(), Point3(0.5 * i, 0.0, 0.0));
    const Key x = MakeKey('x', i);
    Frame& f = frames[i];
    EXPECT_TRUE(f.values.Insert(x, Pose3(Rot3(), truth.translation() + jitter(0.05))).ok());
    if (i == 0) {
      f.factors.Emplace<PriorFactor<Pose3>>(x, truth, odometry);
    } else {
      f.factors.Emplace<BetweenFactor<Pose3>>(MakeKey('x', i - 1), x,
                                              Pose3(Rot3(), Point3(0.5, 0.0, 0.0)), odometry);
    }
    for (int j = 0; j < points; ++j) {
      const Key l = MakeKey('l', j);
      if (i == 0) EXPECT_TRUE(f.values.Insert(l, Point3(world[j] + jitter(0.2))).ok());
      f.factors.Emplace<RelativePointFactor<Pose3, Point3>>(
          x, l, truth.TransformTo(world[j]) + jitter(0.1), seen);
    }
  }
  return frames;
}

// The largest clique (frontal and separator scalars) any step left in the tree, and the final
// estimate after settling.
int LargestClique(const std::vector<Frame>& frames, int max_landmarks_last, Values* settled) {
  auto isam =
      Isam2::Create({.relinearization = {.skip = 1}, .max_landmarks_last = max_landmarks_last})
          .value();
  int largest = 0;
  for (const Frame& f : frames) {
    const Isam2Result r = isam->Update(f.factors, f.values);
    EXPECT_TRUE(r.status.ok()) << r.status.ToString();
    const BayesTree& tree = isam->tree();
    for (int id = 0; id < tree.NumSlots(); ++id) {
      if (!tree.IsLive(id)) continue;
      const Clique& c = tree.clique(id);
      largest = std::max(largest, c.FrontalDim() + c.SeparatorDim());
    }
  }
  for (int k = 0; k < 10; ++k) EXPECT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
  *settled = isam->CalculateEstimate();
  return largest;
}

// Every frame's factors solved at once, from the frames' initial values.
BatchResult BatchOptimum(const std::vector<Frame>& frames) {
  FactorGraph all;
  Values initial;
  for (const Frame& f : frames) {
    for (const FactorPtr& factor : f.factors) all.Add(factor);
    for (int slot = 0; slot < static_cast<int>(f.values.size()); ++slot) {
      EXPECT_TRUE(initial.Insert(f.values.KeyAt(slot), f.values.VariableAt(slot)).ok());
    }
  }
  return Optimize(all, initial, {.relative_tolerance = 1e-12});
}

TEST(Isam2OrderingTest, AFramesManyLandmarksStayOutOfTheRootClique) {
  const std::vector<Frame> frames = VisualStream(12, 30, 1);
  Values free, last;
  const int largest_free = LargestClique(frames, 8, &free);   // 30 landmarks a frame: not last
  const int largest_last = LargestClique(frames, 30, &last);  // all of them last
  // Ordered last, the 30 points (90 scalars) share the root with the poses; otherwise each point
  // is eliminated before the poses that see it (here all 12 of them: 72 scalars) and no clique
  // holds more than one point.
  EXPECT_GE(largest_last, 90 + 6);
  EXPECT_LE(largest_free, 6 * 12 + 3) << largest_free << " against " << largest_last;
  const BatchResult batch = BatchOptimum(frames);
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  EXPECT_LT(testing::MaxDifference(free, batch.values), 1e-6);
  EXPECT_LT(testing::MaxDifference(last, batch.values), 1e-6);
}

// Where landmarks are most of what an update re-eliminates (and more than max_landmarks_last),
// every one of them goes first: each is a leaf clique of its own under the poses that see it,
// update after update, and relinearising everything keeps it so.
TEST(Isam2OrderingTest, ManyLandmarksAreEliminatedFirstAsLeaves) {
  const std::vector<Frame> frames = VisualStream(8, 40, 2);
  auto isam = Isam2::Create({.relinearization = {.skip = 1}}).value();
  const auto expect_leaves = [&](int update) {
    const BayesTree& tree = isam->tree();
    int landmarks = 0;
    for (int id = 0; id < tree.NumSlots(); ++id) {
      if (!tree.IsLive(id)) continue;
      const Clique& c = tree.clique(id);
      const bool has_landmark = std::any_of(c.frontals().begin(), c.frontals().end(), [&](int v) {
        return KeySymbol(isam->linearization_point().KeyAt(v)) == 'l';
      });
      if (!has_landmark) continue;
      ++landmarks;
      EXPECT_EQ(c.num_frontals(), 1) << "update " << update;
      EXPECT_TRUE(c.children().empty()) << "update " << update;
    }
    EXPECT_EQ(landmarks, 40) << "update " << update;
  };
  for (size_t i = 0; i < frames.size(); ++i) {
    ASSERT_TRUE(isam->Update(frames[i].factors, frames[i].values).status.ok());
    expect_leaves(static_cast<int>(i));
  }
  ASSERT_TRUE(isam->Update({}, {}, {.force_full = true}).status.ok());
  expect_leaves(-1);
}

// Ties two landmarks (no factor that ships does; a user's may): their offset, b − a.
class PointOffsetFactor : public TypedFactor<PointOffsetFactor, 3, Point3, Point3> {
  using Base = TypedFactor<PointOffsetFactor, 3, Point3, Point3>;
  using Jacobian = Base::JacobianAt<0>;

 public:
  static const char* TypeName() { return "TestPointOffset"; }
  PointOffsetFactor(Key a, Key b, const Point3& offset, NoiseModel noise)
      : Base({a, b}, std::move(noise), RobustKernel{}), offset_(offset) {}
  void EncodeMeasured(std::vector<double>* out) const override {
    out->insert(out->end(), offset_.data(), offset_.data() + 3);
  }
  Base::ErrorVector Evaluate(const Point3& a, const Point3& b, Jacobian* Ha, Jacobian* Hb) const {
    if (Ha) *Ha = -Jacobian::Identity();
    if (Hb) *Hb = Jacobian::Identity();
    return b - a - offset_;
  }

 private:
  Point3 offset_;
};

// Landmarks that a factor ties together are not an independent set: the top is ordered by
// CCOLAMD as before, and the steps still settle at the batch optimum.
TEST(Isam2OrderingTest, LandmarksTiedTogetherAreOrderedByColamd) {
  std::vector<Frame> frames = VisualStream(12, 30, 1);
  frames[2].factors.Emplace<PointOffsetFactor>(MakeKey('l', 0), MakeKey('l', 1),
                                               Point3(0.6, 0.0, 0.0),  // their true offset
                                               NoiseModel::Isotropic(3, 0.1).value());
  Values settled;
  LargestClique(frames, 8, &settled);  // every update succeeds (checked inside)
  const BatchResult batch = BatchOptimum(frames);
  ASSERT_TRUE(batch.status.ok()) << batch.status.ToString();
  EXPECT_LT(testing::MaxDifference(settled, batch.values), 1e-6);
}

}  // namespace
}  // namespace slamd::core
