// Valid example messages of every inbound type (tests mutate one field at a time).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "slamd/camera_info_t.hpp"
#include "slamd/frame_observations_t.hpp"
#include "slamd/key_t.hpp"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "slamd/shard_summary_t.hpp"

namespace slamd::server::testing {

// A d x d symmetric positive definite covariance, row-major: diagonally dominant with distinct
// diagonal entries and non-zero off-diagonal ones (so row/column order mistakes show).
inline std::vector<double> SpdCovariance(int d, double scale = 0.01) {
  std::vector<double> c(d * d);
  for (int i = 0; i < d; ++i) {
    for (int j = 0; j < d; ++j) {
      c[i * d + j] = i == j ? scale * (i + 1)
                            : scale * 0.1 / (1.0 + std::abs(i - j)) * (i + j + 1) / (2.0 * d);
    }
  }
  return c;
}

// A unit quaternion (w, x, y, z) of a generic rotation.
inline std::vector<double> UnitQuaternion() {
  const double w = 0.9, x = 0.1, y = -0.3, z = 0.2;
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  return {w / n, x / n, y / n, z / n};
}

template <typename Msg>
void SetArrays(std::vector<double> values, int cov_dim, Msg* m) {
  m->values = std::move(values);
  m->num_values = static_cast<int>(m->values.size());
  m->covariance = SpdCovariance(cov_dim);
  m->num_covariance = static_cast<int>(m->covariance.size());
}

inline std::vector<double> Pose3Values() {
  std::vector<double> v = {1.0, -2.0, 0.5};
  for (double q : UnitQuaternion()) v.push_back(q);
  return v;
}

inline slamd::odometry_t Odometry2() {
  slamd::odometry_t m;
  m.utime = 1700000000000000;
  m.robot = "alpha";
  m.from_index = 4;
  m.to_index = 5;
  m.dimension = 2;
  SetArrays({1.0, 0.1, 0.05}, 3, &m);
  return m;
}

inline slamd::odometry_t Odometry3() {
  slamd::odometry_t m = Odometry2();
  m.dimension = 3;
  SetArrays(Pose3Values(), 6, &m);
  return m;
}

inline slamd::landmark_observation_t Landmark(int kind) {
  slamd::landmark_observation_t m;
  m.utime = 1700000000000001;
  m.robot = "alpha";
  m.pose_index = 5;
  m.landmark_id = 17;
  m.kind = static_cast<int8_t>(kind);
  m.landmark_namespace = slamd::landmark_observation_t::NAMESPACE_ROBOT;
  if (kind == 1) SetArrays({0.3, 4.0}, 2, &m);
  if (kind == 2) SetArrays({3.0, -1.5}, 2, &m);
  if (kind == 3) SetArrays({3.0, -1.5, 0.7}, 3, &m);
  return m;
}

inline slamd::loop_closure_t LoopClosure2() {
  slamd::loop_closure_t m;
  m.utime = 1700000000000002;
  m.robot_a = "alpha";
  m.pose_a = 100;
  m.robot_b = "bravo";
  m.pose_b = 3;
  m.dimension = 2;
  SetArrays({-0.5, 2.0, 3.0}, 3, &m);
  m.robust_kernel = "huber";
  m.robust_parameter = 1.345;
  return m;
}

inline slamd::loop_closure_t LoopClosure3() {
  slamd::loop_closure_t m = LoopClosure2();
  m.dimension = 3;
  SetArrays(Pose3Values(), 6, &m);
  m.robust_kernel = "";
  m.robust_parameter = 0.0;
  return m;
}

inline slamd::prior_t Prior(int kind) {
  slamd::prior_t m;
  m.utime = 1700000000000003;
  m.robot = "alpha";
  m.pose_index = 0;
  m.kind = static_cast<int8_t>(kind);
  if (kind == 1) SetArrays({10.0, 20.0, -2.5}, 3, &m);
  if (kind == 2) SetArrays(Pose3Values(), 6, &m);
  if (kind == 3) SetArrays({10.0, 20.0}, 2, &m);
  if (kind == 4) SetArrays({10.0, 20.0, 1.5}, 3, &m);
  return m;
}

// target: 1 odometry, 2 landmark observation, 3 loop closure, 4 prior.
inline slamd::remove_factor_t RemoveFactor(int target) {
  slamd::remove_factor_t m;
  m.utime = 1700000000000004;
  m.target = static_cast<int8_t>(target);
  m.robot_a = "alpha";
  m.index_a = 4;
  m.robot_b = target == 3 ? "bravo" : "";
  m.index_b = target == 4 ? 0 : 5;
  m.kind = target == 2 ? 1 : target == 4 ? 3 : 0;
  return m;
}

inline slamd::key_t Key(const std::string& robot, int kind, int64_t index) {
  slamd::key_t k;
  k.robot = robot;
  k.kind = static_cast<int8_t>(kind);
  k.index = index;
  return k;
}

inline slamd::query_t Query() {
  slamd::query_t m;
  m.utime = 1700000000000005;
  m.client = "slamctl-1";
  m.request_id = 42;
  m.keys = {Key("alpha", 1, 4), Key("alpha", 2, 17), Key("bravo", 1, 3)};
  m.num_keys = 3;
  m.want_marginals = true;
  m.want_joint_marginal = true;
  m.map_robot = "alpha";
  return m;
}

// A pinhole camera (model 1) or a stereo pair (model 4) of robot "alpha", 640 x 480.
inline slamd::camera_info_t CameraInfoMessage(int model = 1) {
  slamd::camera_info_t m;
  m.utime = 1700000000000000;
  m.robot = "alpha";
  m.camera_id = 1;
  m.from_pose_index = 0;
  m.model = static_cast<std::int8_t>(model);
  m.intrinsics = {400.0, 410.0, 0.0, 320.0, 240.0};
  if (model == 2) m.intrinsics = {400.0, 410.0, 0.0, 320.0, 240.0, -0.1, 0.01, 1e-3, -1e-3};
  if (model == 3) m.intrinsics = {400.0, -0.1, 0.01};
  if (model == 4) m.intrinsics.push_back(0.12);
  m.num_intrinsics = static_cast<int>(m.intrinsics.size());
  const std::vector<double> q = UnitQuaternion();
  for (int i = 0; i < 3; ++i) m.body_t_camera[i] = 0.1 * (i + 1);
  for (int i = 0; i < 4; ++i) m.body_q_camera[i] = q[i];
  m.width = 640;
  m.height = 480;
  return m;
}

// Three features of a mono (kind 1) or stereo (kind 2) frame of "alpha" pose 5, camera 1, one
// sigma each (or, with `covariance`, a covariance each).
inline slamd::frame_observations_t FrameMessage(int kind = 1, bool covariance = false) {
  slamd::frame_observations_t m;
  m.utime = 1700000000000000;
  m.robot = "alpha";
  m.pose_index = 5;
  m.camera_id = 1;
  m.kind = static_cast<std::int8_t>(kind);
  m.landmark_namespace = 0;
  m.landmark_ids = {10, 11, 42};
  m.num_features = 3;
  m.values = kind == 1
                 ? std::vector<double>{100.5, 200.25, 320.0, 240.0, 10.0, 470.0}
                 : std::vector<double>{100.5, 90.5, 200.25, 320.0, 318.0, 240.0, 10.0, 9.0, 470.0};
  m.num_values = static_cast<int>(m.values.size());
  const int dim = kind == 1 ? 2 : 3;
  if (covariance) {
    for (int k = 0; k < 3; ++k) {
      const std::vector<double> c = SpdCovariance(dim, 0.5 + k);
      m.covariance.insert(m.covariance.end(), c.begin(), c.end());
    }
  } else {
    m.sigmas = {0.5, 1.0, 2.0};
  }
  m.num_sigmas = static_cast<int>(m.sigmas.size());
  m.num_covariance = static_cast<int>(m.covariance.size());
  m.robust_kernel = "huber";
  m.robust_parameter = 1.345;
  return m;
}

// A summary from shard "east" to "west" on two 2D poses (alpha:4, bravo:3) and a landmark of
// the shared map (m7): an upper-triangular 5 x 8 A (rows < columns, as when some directions
// carry nothing); east holds the map landmarks 2, 7 and 9.
inline slamd::shard_summary_t ShardSummary() {
  slamd::shard_summary_t m;
  m.utime = 1700000000000009;
  m.from_shard = "east";
  m.to_shard = "west";
  m.dimension = 2;
  m.keys = {Key("alpha", 1, 4), Key("bravo", 1, 3), Key("", 3, 7)};
  m.num_keys = 3;
  m.values = {1.0, 2.0, 0.5, -1.0, 0.25, -3.0, 4.0, 5.0};
  m.num_values = 8;
  m.rows = 5;
  m.b = {0.1, -0.2, 0.0, 0.3, 0.4};
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 8; ++c) m.a.push_back(c >= r ? 1.0 + r + 0.5 * c : 0.0);
  }
  m.num_a = 40;
  m.map_landmarks = {2, 7, 9};
  m.num_map_landmarks = 3;
  return m;
}

}  // namespace slamd::server::testing
