// Convert (LCM -> core) against independently computed values, and ToLcm (core -> LCM) round trips.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "server/messages/inbound.h"
#include "tests/server/ingest/test_messages.h"

namespace slamd::server {
namespace {

using namespace testing;  // NOLINT: the example messages

// The covariance a message carries, as a matrix.
template <typename Msg>
Eigen::MatrixXd CovarianceOf(const Msg& m) {
  const int d = static_cast<int>(std::lround(std::sqrt(m.covariance.size())));
  Eigen::MatrixXd C(d, d);
  for (int i = 0; i < d; ++i)
    for (int j = 0; j < d; ++j) C(i, j) = m.covariance[i * d + j];
  return C;
}

template <typename Msg>
void ExpectSameArrays(const Msg& a, const Msg& b, double tol) {
  ASSERT_EQ(a.num_values, b.num_values);
  ASSERT_EQ(a.values.size(), b.values.size());
  for (size_t i = 0; i < a.values.size(); ++i)
    EXPECT_NEAR(a.values[i], b.values[i], tol) << "values[" << i << "]";
  ASSERT_EQ(a.num_covariance, b.num_covariance);
  ASSERT_EQ(a.covariance.size(), b.covariance.size());
  for (size_t i = 0; i < a.covariance.size(); ++i) {
    EXPECT_NEAR(a.covariance[i], b.covariance[i], tol * 1e-2) << "covariance[" << i << "]";
  }
}

TEST(Convert, Odometry2) {
  const auto msg = Odometry2();
  const auto odo = Convert(msg);
  ASSERT_TRUE(odo.ok()) << odo.verdict().message;
  const OdometryMeasurement& m = odo.value();
  EXPECT_EQ(m.utime, msg.utime);
  EXPECT_EQ(m.robot, "alpha");
  EXPECT_EQ(m.from_index, 4u);
  EXPECT_EQ(m.to_index, 5u);
  const auto& pose = std::get<core::Pose2>(m.measured);
  EXPECT_DOUBLE_EQ(pose.x(), 1.0);
  EXPECT_DOUBLE_EQ(pose.y(), 0.1);
  EXPECT_NEAR(pose.theta(), 0.05, 1e-15);
  EXPECT_LT((m.noise.Covariance() - CovarianceOf(msg)).cwiseAbs().maxCoeff(), 1e-15);

  slamd::odometry_t back;
  ToLcm(m, &back);
  EXPECT_EQ(back.utime, msg.utime);
  EXPECT_EQ(back.robot, msg.robot);
  EXPECT_EQ(back.from_index, msg.from_index);
  EXPECT_EQ(back.to_index, msg.to_index);
  EXPECT_EQ(back.dimension, 2);
  ExpectSameArrays(back, msg, 1e-12);
}

TEST(Convert, Odometry3RotationMatchesTheQuaternion) {
  const auto msg = Odometry3();
  const auto odo = Convert(msg);
  ASSERT_TRUE(odo.ok()) << odo.verdict().message;
  const auto& pose = std::get<core::Pose3>(odo.value().measured);
  // Independent reference: the rotation matrix of the unit quaternion, written out.
  const double w = msg.values[3], x = msg.values[4], y = msg.values[5], z = msg.values[6];
  Eigen::Matrix3d R;
  R << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),   //
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  EXPECT_LT((pose.rotation().matrix() - R).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(pose.translation(), core::Point3(1.0, -2.0, 0.5));
  EXPECT_EQ(odo.value().noise.dim(), 6);
  EXPECT_LT((odo.value().noise.Covariance() - CovarianceOf(msg)).cwiseAbs().maxCoeff(), 1e-15);

  slamd::odometry_t back;
  ToLcm(odo.value(), &back);
  EXPECT_EQ(back.dimension, 3);
  ExpectSameArrays(back, msg, 1e-12);  // qw > 0 in the example, so the sign is kept
}

TEST(Convert, QuaternionIsNormalisedAndSignCanonicalised) {
  auto msg = Odometry3();
  for (int i = 3; i < 7; ++i) msg.values[i] *= -1.00005;  // -q, slightly long: same rotation
  const auto odo = Convert(msg);
  ASSERT_TRUE(odo.ok()) << odo.verdict().message;
  slamd::odometry_t back;
  ToLcm(odo.value(), &back);
  const Eigen::Vector4d q(back.values[3], back.values[4], back.values[5], back.values[6]);
  EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  EXPECT_GE(q[0], 0.0);
  const auto canonical = Odometry3();
  for (int i = 3; i < 7; ++i) EXPECT_NEAR(back.values[i], canonical.values[i], 1e-14);
}

TEST(Convert, AngleIsWrappedOnTheWayBackAndDescribesTheSamePose) {
  auto msg = Odometry2();
  msg.values[2] = 4.0;  // > pi
  const auto odo = Convert(msg);
  ASSERT_TRUE(odo.ok());
  slamd::odometry_t back;
  ToLcm(odo.value(), &back);
  EXPECT_NEAR(back.values[2], 4.0 - 2 * std::numbers::pi, 1e-14);
  const auto again = Convert(back);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(std::get<core::Pose2>(again.value().measured)
                  .Equals(std::get<core::Pose2>(odo.value().measured), 1e-14));
}

TEST(Convert, LandmarkKinds) {
  {
    const auto c = Convert(Landmark(1));
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(c.value().kind, LandmarkKind::kBearingRange2);
    const auto& br = std::get<BearingRange>(c.value().measured);
    EXPECT_EQ(br.bearing, 0.3);
    EXPECT_EQ(br.range, 4.0);
    EXPECT_EQ(c.value().landmark_id, 17u);
    EXPECT_EQ(c.value().pose_index, 5u);
  }
  {
    const auto c = Convert(Landmark(2));
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(std::get<core::Point2>(c.value().measured), core::Point2(3.0, -1.5));
  }
  {
    const auto c = Convert(Landmark(3));
    ASSERT_TRUE(c.ok());
    EXPECT_EQ(std::get<core::Point3>(c.value().measured), core::Point3(3.0, -1.5, 0.7));
    EXPECT_EQ(c.value().noise.dim(), 3);
  }
  for (int kind = 1; kind <= 3; ++kind) {
    const auto msg = Landmark(kind);
    slamd::landmark_observation_t back;
    ToLcm(Convert(msg).value(), &back);
    EXPECT_EQ(back.kind, kind);
    EXPECT_EQ(back.landmark_id, msg.landmark_id);
    ExpectSameArrays(back, msg, 1e-12);
  }
}

TEST(Convert, LoopClosureWithRobustKernel) {
  const auto msg = LoopClosure2();
  const auto lc = Convert(msg);
  ASSERT_TRUE(lc.ok()) << lc.verdict().message;
  EXPECT_EQ(lc.value().robot_a, "alpha");
  EXPECT_EQ(lc.value().robot_b, "bravo");
  EXPECT_EQ(lc.value().pose_a, 100u);
  EXPECT_EQ(lc.value().pose_b, 3u);
  EXPECT_EQ(lc.value().robust.kind(), core::RobustKernel::Kind::kHuber);
  EXPECT_EQ(lc.value().robust.parameter(), 1.345);
  slamd::loop_closure_t back;
  ToLcm(lc.value(), &back);
  EXPECT_EQ(back.robust_kernel, "huber");
  EXPECT_EQ(back.robust_parameter, 1.345);
  ExpectSameArrays(back, msg, 1e-12);

  const auto plain = Convert(LoopClosure3());
  ASSERT_TRUE(plain.ok());
  EXPECT_TRUE(plain.value().robust.is_none());
  ToLcm(plain.value(), &back);
  EXPECT_EQ(back.robust_kernel, "");
  EXPECT_EQ(back.dimension, 3);
}

TEST(Convert, PriorKinds) {
  EXPECT_TRUE(std::get<core::Pose2>(Convert(Prior(1)).value().measured)
                  .Equals(core::Pose2(10, 20, -2.5), 1e-15));
  EXPECT_EQ(std::get<core::Pose3>(Convert(Prior(2)).value().measured).translation(),
            core::Point3(1.0, -2.0, 0.5));
  EXPECT_EQ(std::get<core::Point2>(Convert(Prior(3)).value().measured), core::Point2(10, 20));
  EXPECT_EQ(std::get<core::Point3>(Convert(Prior(4)).value().measured), core::Point3(10, 20, 1.5));
  for (int kind = 1; kind <= 4; ++kind) {
    const auto msg = Prior(kind);
    const auto c = Convert(msg);
    ASSERT_TRUE(c.ok()) << c.verdict().message;
    EXPECT_EQ(static_cast<int>(c.value().kind), kind);
    slamd::prior_t back;
    ToLcm(c.value(), &back);
    EXPECT_EQ(back.kind, kind);
    EXPECT_EQ(back.pose_index, msg.pose_index);
    ExpectSameArrays(back, msg, 1e-12);
  }
}

TEST(Convert, RemoveFactorRoundTripsExactly) {
  for (int target = 1; target <= 4; ++target) {
    const auto msg = RemoveFactor(target);
    const auto c = Convert(msg);
    ASSERT_TRUE(c.ok()) << c.verdict().message;
    EXPECT_EQ(static_cast<int>(c.value().target), target);
    slamd::remove_factor_t back;
    ToLcm(c.value(), &back);
    EXPECT_EQ(back.utime, msg.utime);
    EXPECT_EQ(back.target, msg.target);
    EXPECT_EQ(back.robot_a, msg.robot_a);
    EXPECT_EQ(back.index_a, msg.index_a);
    EXPECT_EQ(back.robot_b, msg.robot_b);
    EXPECT_EQ(back.index_b, msg.index_b);
    EXPECT_EQ(back.kind, msg.kind);
  }
}

TEST(Convert, QueryRoundTripsExactly) {
  const auto msg = Query();
  const auto c = Convert(msg);
  ASSERT_TRUE(c.ok()) << c.verdict().message;
  const QueryRequest& q = c.value();
  ASSERT_EQ(q.keys.size(), 3u);
  EXPECT_EQ(q.keys[1], (WireKey{.robot = "alpha", .kind = KeyKind::kLandmark, .index = 17}));
  EXPECT_TRUE(q.want_marginals);
  EXPECT_TRUE(q.want_joint_marginal);
  slamd::query_t back;
  ToLcm(q, &back);
  EXPECT_EQ(back.client, msg.client);
  EXPECT_EQ(back.request_id, msg.request_id);
  ASSERT_EQ(back.num_keys, msg.num_keys);
  for (int i = 0; i < back.num_keys; ++i) {
    EXPECT_EQ(back.keys[i].robot, msg.keys[i].robot);
    EXPECT_EQ(back.keys[i].kind, msg.keys[i].kind);
    EXPECT_EQ(back.keys[i].index, msg.keys[i].index);
  }
  EXPECT_EQ(back.want_marginals, msg.want_marginals);
  EXPECT_EQ(back.map_robot, msg.map_robot);
}

TEST(Convert, CameraInfoOfEveryModelRoundTrips) {
  for (int model = 1; model <= 4; ++model) {
    const auto msg = CameraInfoMessage(model);
    const auto c = Convert(msg);
    ASSERT_TRUE(c.ok()) << c.verdict().message;
    const CameraModel& camera = c.value().camera;
    EXPECT_EQ(camera.stereo(), model == 4);
    EXPECT_EQ(static_cast<int>(camera.calibration.index()), model == 4 ? 0 : model - 1);
    const Eigen::VectorXd k =
        std::visit([](const auto& K) { return Eigen::VectorXd(K.vector()); }, camera.calibration);
    for (int i = 0; i < k.size(); ++i) EXPECT_EQ(k[i], msg.intrinsics[i]) << "model " << model;
    // The mount: camera (0, 0, 1) in the body frame is R·e_z + t.
    const Eigen::Quaterniond q(msg.body_q_camera[0], msg.body_q_camera[1], msg.body_q_camera[2],
                               msg.body_q_camera[3]);
    const core::Point3 t(msg.body_t_camera[0], msg.body_t_camera[1], msg.body_t_camera[2]);
    EXPECT_LT((camera.body_P_camera.TransformFrom(core::Point3(0, 0, 1)) -
               (q.normalized() * core::Point3(0, 0, 1) + t))
                  .norm(),
              1e-12);
    slamd::camera_info_t back;
    ToLcm(c.value(), &back);
    EXPECT_EQ(back.model, msg.model);
    ASSERT_EQ(back.intrinsics.size(), msg.intrinsics.size());
    for (std::size_t i = 0; i < back.intrinsics.size(); ++i) {
      EXPECT_EQ(back.intrinsics[i], msg.intrinsics[i]);
    }
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(back.body_q_camera[i], msg.body_q_camera[i], 1e-12);
    EXPECT_EQ(back.width, msg.width);
    EXPECT_EQ(back.height, msg.height);
  }
}

TEST(Convert, FrameObservationsKeepEachFeaturesPixelAndNoise) {
  for (const bool covariance : {false, true}) {
    for (int kind = 1; kind <= 2; ++kind) {
      const auto msg = FrameMessage(kind, covariance);
      const auto c = Convert(msg);
      ASSERT_TRUE(c.ok()) << c.verdict().message;
      const FrameObservations& f = c.value();
      ASSERT_EQ(f.features.size(), 3u);
      EXPECT_EQ(f.stereo, kind == 2);
      const int dim = kind == 1 ? 2 : 3;
      for (int k = 0; k < 3; ++k) {
        const FrameFeature& feature = f.features[k];
        EXPECT_EQ(feature.landmark_id, static_cast<std::uint64_t>(msg.landmark_ids[k]));
        EXPECT_EQ(feature.index, k);
        EXPECT_EQ(feature.uv.x(), msg.values[dim * k]);
        EXPECT_EQ(feature.uv.y(), msg.values[dim * k + dim - 1]);  // v last
        if (kind == 2) {
          EXPECT_EQ(feature.u_right, msg.values[dim * k + 1]);
        }
        const Eigen::MatrixXd C = feature.noise.Covariance();
        for (int i = 0; i < dim; ++i) {
          for (int j = 0; j < dim; ++j) {
            const double expected = covariance ? msg.covariance[k * dim * dim + i * dim + j]
                                               : (i == j ? msg.sigmas[k] * msg.sigmas[k] : 0.0);
            EXPECT_NEAR(C(i, j), expected, 1e-12);
          }
        }
      }
      slamd::frame_observations_t back;
      ToLcm(f, &back);
      EXPECT_EQ(back.landmark_ids, msg.landmark_ids);
      EXPECT_EQ(back.values, msg.values);
      ASSERT_EQ(back.sigmas.size(), msg.sigmas.size());
      for (std::size_t i = 0; i < back.sigmas.size(); ++i) {
        EXPECT_NEAR(back.sigmas[i], msg.sigmas[i], 1e-12);
      }
      ASSERT_EQ(back.covariance.size(), msg.covariance.size());
      for (std::size_t i = 0; i < back.covariance.size(); ++i) {
        EXPECT_NEAR(back.covariance[i], msg.covariance[i], 1e-12);
      }
      EXPECT_EQ(back.robust_kernel, "huber");
      EXPECT_EQ(back.robust_parameter, msg.robust_parameter);
    }
  }
}

TEST(Convert, RejectedMessageGivesTheVerdictOnly) {
  auto msg = Odometry2();
  msg.covariance[0] = -1.0;
  const auto c = Convert(msg);
  EXPECT_FALSE(c.ok());
  EXPECT_EQ(c.verdict().reason, RejectReason::kCovarianceNotPositiveDefinite);
  auto q = Query();
  q.num_keys = 7;
  EXPECT_EQ(Convert(q).verdict().reason, RejectReason::kSizeMismatch);
  auto r = RemoveFactor(2);
  r.kind = 9;
  EXPECT_EQ(Convert(r).verdict().reason, RejectReason::kBadKind);
}

}  // namespace
}  // namespace slamd::server
