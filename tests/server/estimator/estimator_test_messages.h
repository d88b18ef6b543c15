// Messages, estimators and checks shared by the estimator's tests (estimator_test.cc,
// background_rebuild_test.cc).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "server/estimator/estimator.h"
#include "tests/testing/noise.h"

namespace slamd::server::estimator_test {

using core::Pose2;
using ::slamd::testing::Noise;

inline Inbound Odo(const std::string& robot, std::uint64_t from, std::uint64_t to, const Pose2& z) {
  return {OdometryMeasurement{1, robot, from, to, z, Noise(3, 0.1)}, 0};
}
inline Inbound Loop(const std::string& a, std::uint64_t pa, const std::string& b, std::uint64_t pb,
                    const Pose2& z) {
  return {LoopClosureMeasurement{2, a, pa, b, pb, z, Noise(3, 0.2), {}}, 0};
}
inline Inbound Prior(const std::string& robot, std::uint64_t index, const Pose2& p) {
  return {PriorMeasurement{3, robot, index, PriorKind::kPose2, p, Noise(3, 0.01)}, 0};
}
inline Inbound Landmark(const std::string& robot, std::uint64_t pose, std::uint64_t id, double b,
                        double r, LandmarkNamespace ns = LandmarkNamespace::kRobot) {
  return {LandmarkMeasurement{4, robot, pose, id, LandmarkKind::kBearingRange2, BearingRange{b, r},
                              Noise(2, 0.05), ns},
          0};
}

inline Inbound Remove(RemoveTarget target, const std::string& a, std::uint64_t ia,
                      const std::string& b, std::uint64_t ib, std::int8_t kind = 0) {
  return {RemoveFactorRequest{6, target, a, ia, b, ib, kind}, 0};
}

// chi2 after every update (the tests compare it), unless a test says otherwise.
inline std::unique_ptr<Estimator> Make(EstimatorParams p = {.chi2_interval_s = 0.0}, int skip = 1) {
  core::Isam2Params isam2;
  isam2.relinearization.skip = skip;
  return Estimator::Create(p, isam2).value();
}

inline Pose2 PoseOf(const Estimator& e, const std::string& robot, std::uint64_t i) {
  return std::get<Pose2>(e.PoseEstimate(robot, i).value());
}

inline void ExpectNear(const Pose2& a, const Pose2& b, double tol) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(std::remainder(a.theta() - b.theta(), 2 * M_PI), 0.0, tol);
}

inline RejectReason OnlyRejection(const ProcessResult& r) {
  EXPECT_EQ(r.rejections.size(), 1u);
  return r.rejections.empty() ? RejectReason::kNone : r.rejections[0].verdict.reason;
}

inline const Pose2 kStep(1.0, 0.1, 0.2);

// A corridor walked back and forth, one batch per pose after the prior on pose 0: every 25
// poses a loop closure, 0.3 m off, to the pose 100 back. Large enough for a rebuild to take
// long against its updates.
inline std::vector<std::vector<Inbound>> CorridorBatches(int poses) {
  std::vector<std::vector<Inbound>> batches = {{Prior("r", 0, Pose2())}};
  Pose2 hundred = Pose2();
  for (int k = 0; k < 100; ++k) hundred = hundred * kStep;
  for (int i = 0; i < poses; ++i) {
    std::vector<Inbound> batch = {Odo("r", i, i + 1, kStep)};
    if (i >= 100 && i % 25 == 0) {
      batch.push_back(Loop("r", i + 1, "r", i - 99, hundred.Inverse() * Pose2(0.3, 0.0, 0.05)));
    }
    batches.push_back(std::move(batch));
  }
  return batches;
}

}  // namespace slamd::server::estimator_test
