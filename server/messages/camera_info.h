// camera_info_t (msgs/lcm/camera_info_t.lcm): a robot's camera, its intrinsics, where it sits on
// the body and its image size, valid for the frames of poses from `from_pose_index` on.
//
// Applied: no factor; the camera joins the estimator's camera table (CameraTable), which
// frame_observations_t looks up by (robot, camera_id, pose index). A different camera_info_t
// with the same (robot, camera_id, from_pose_index) as one applied is a duplicate (send a
// recalibration with the pose it starts at); the same one again is already held.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "core/geometry/calibration.h"
#include "core/geometry/pose3.h"
#include "server/ingest/conversion.h"
#include "server/messages/message_spec.h"
#include "slamd/camera_info_t.hpp"

namespace slamd::server {

// A camera as frames are projected through it.
struct CameraModel {
  core::Calibration calibration = core::Cal3_S2();
  double baseline = 0.0;      // > 0: a rectified stereo pair (calibration a Cal3_S2)
  core::Pose3 body_P_camera;  // camera -> body
  int width = 0;              // image size [px]
  int height = 0;

  bool stereo() const { return baseline > 0.0; }
  // Whether pixel (u, v) lies in the image: [0, width) x [0, height), or for Cal3Bundler, whose
  // pixels are measured from the image centre (BAL's), [-width/2, width/2) x [-height/2, ...).
  bool Inside(double u, double v) const;
  bool operator==(const CameraModel& o) const;
};

struct CameraInfo {
  std::int64_t utime;
  std::string robot;
  int camera_id;  // 0..255
  std::uint64_t from_pose_index;
  CameraModel camera;
};

Verdict Validate(const slamd::camera_info_t& msg, const Limits& limits = {});
Checked<CameraInfo> Convert(const slamd::camera_info_t& msg, const Limits& limits = {});
void ToLcm(const CameraInfo& m, slamd::camera_info_t* out);

// The cameras the estimator knows, by (robot id, camera id, from_pose_index). Adds since the last
// Commit can be undone (an update the solver refused undoes its batch). Estimator thread only.
class CameraTable {
 public:
  // The camera of `robot`'s frames at pose `pose_index`: the one with the largest
  // from_pose_index <= pose_index; null when none.
  const CameraModel* Find(std::uint8_t robot, int camera_id, std::uint64_t pose_index) const;
  // The camera registered exactly at from_pose_index, or null.
  const CameraModel* FindExact(std::uint8_t robot, int camera_id,
                               std::uint64_t from_pose_index) const;
  void Add(std::uint8_t robot, int camera_id, std::uint64_t from_pose_index,
           const CameraModel& camera);
  void Commit() { added_.clear(); }
  void Rollback();
  // f(robot, camera_id, from_pose_index, camera) in key order.
  template <typename F>
  void ForEach(F&& f) const {
    for (const auto& [key, camera] : cameras_) {
      f(std::get<0>(key), std::get<1>(key), std::get<2>(key), camera);
    }
  }
  int size() const { return static_cast<int>(cameras_.size()); }

 private:
  using Id = std::tuple<std::uint8_t, int, std::uint64_t>;
  std::map<Id, CameraModel> cameras_;
  std::vector<Id> added_;  // since the last Commit
};

struct CameraInfoSpec {
  using Lcm = slamd::camera_info_t;
  using Value = CameraInfo;
  static constexpr const char* kType = "camera_info_t";
  static constexpr const char* kChannel = "CAMERA_INFO";
  static constexpr MessageRole kRole = MessageRole::kMeasurement;

  template <typename M>
  static const std::string& Robot(const M& m) {
    return m.robot;
  }
  static Outcome Apply(const Value& m, GraphBuilder& graph, Verdict* verdict);
};

}  // namespace slamd::server
