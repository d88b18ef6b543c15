#include "server/messages/camera_info.h"

#include <iterator>
#include <variant>

#include "server/ingest/field_checks.h"

namespace slamd::server {
namespace {

using C = ::slamd::camera_info_t;
using internal::CheckCount;
using internal::CheckFinite;
using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckName;
using internal::CheckUnitQuaternion;
using internal::CheckUtime;
using internal::FormatNumber;
using internal::Reject;

constexpr int kNumIntrinsics[] = {5, 9, 3, 6};  // by model - 1
constexpr const char* kModels = "1 (pinhole), 2 (radtan), 3 (bundler), 4 (stereo)";
constexpr int kMaxImageSize = 65536;

}  // namespace

bool CameraModel::operator==(const CameraModel& o) const {
  return calibration.index() == o.calibration.index() &&
         std::visit(
             [&](const auto& k) {
               return k.vector() == std::get<std::decay_t<decltype(k)>>(o.calibration).vector();
             },
             calibration) &&
         baseline == o.baseline && body_P_camera.matrix() == o.body_P_camera.matrix() &&
         width == o.width && height == o.height;
}

bool CameraModel::Inside(double u, double v) const {
  if (std::holds_alternative<core::Cal3Bundler>(calibration)) {
    u += 0.5 * width;
    v += 0.5 * height;
  }
  return u >= 0 && u < width && v >= 0 && v < height;
}

Verdict Validate(const slamd::camera_info_t& msg, const Limits& limits) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("camera_info_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("camera_info_t.robot", msg.robot, limits.max_robot_name_length));
  if (msg.camera_id < 0 || msg.camera_id > 255) {
    return Reject(RejectReason::kIndexOutOfRange, "camera_info_t.camera_id",
                  std::to_string(msg.camera_id) + " is outside 0..255");
  }
  SLAMD_RETURN_IF_REJECTED(CheckIndex("camera_info_t.from_pose_index", msg.from_pose_index));
  SLAMD_RETURN_IF_REJECTED(
      CheckKindRange("camera_info_t.model", msg.model, C::MODEL_PINHOLE, C::MODEL_STEREO, kModels));
  SLAMD_RETURN_IF_REJECTED(CheckCount("camera_info_t.num_intrinsics", msg.num_intrinsics,
                                      msg.intrinsics.size(), kNumIntrinsics[msg.model - 1],
                                      "this model"));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("camera_info_t.intrinsics", msg.intrinsics));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("camera_info_t.body_t_camera", msg.body_t_camera));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("camera_info_t.body_q_camera", msg.body_q_camera));
  SLAMD_RETURN_IF_REJECTED(CheckUnitQuaternion(
      "camera_info_t.body_q_camera", msg.body_q_camera[0], msg.body_q_camera[1],
      msg.body_q_camera[2], msg.body_q_camera[3], limits.quaternion_norm_tolerance));
  const bool two_focal = msg.model != C::MODEL_BUNDLER;
  for (int i = 0; i < (two_focal ? 2 : 1); ++i) {
    if (!(msg.intrinsics[i] > 0.0)) {
      return Reject(RejectReason::kBadMeasurement,
                    "camera_info_t.intrinsics[" + std::to_string(i) + "]",
                    "focal length " + FormatNumber(msg.intrinsics[i]) + " px is not positive");
    }
  }
  if (msg.model == C::MODEL_STEREO && !(msg.intrinsics[5] > 0.0)) {
    return Reject(RejectReason::kBadMeasurement, "camera_info_t.intrinsics[5]",
                  "baseline " + FormatNumber(msg.intrinsics[5]) + " m is not positive");
  }
  for (const auto& [field, size] : {std::pair{"camera_info_t.width", msg.width},
                                    std::pair{"camera_info_t.height", msg.height}}) {
    if (size < 1 || size > kMaxImageSize) {
      return Reject(RejectReason::kBadMeasurement, field,
                    std::to_string(size) + " px is outside 1..65536");
    }
  }
  return {};
}

Checked<CameraInfo> Convert(const slamd::camera_info_t& msg, const Limits& limits) {
  Verdict verdict = Validate(msg, limits);
  if (!verdict.ok()) return verdict;
  const std::vector<double>& k = msg.intrinsics;
  CameraModel camera{.body_P_camera = {}, .width = msg.width, .height = msg.height};
  switch (msg.model) {
    case C::MODEL_PINHOLE:
      camera.calibration = core::Cal3_S2(k[0], k[1], k[2], k[3], k[4]);
      break;
    case C::MODEL_RADTAN:
      camera.calibration =
          core::Cal3DS2(core::Cal3_S2(k[0], k[1], k[2], k[3], k[4]), k[5], k[6], k[7], k[8]);
      break;
    case C::MODEL_BUNDLER:
      camera.calibration = core::Cal3Bundler(k[0], k[1], k[2]);
      break;
    default:  // MODEL_STEREO
      camera.calibration = core::Cal3_S2(k[0], k[1], k[2], k[3], k[4]);
      camera.baseline = k[5];
  }
  const double* q = msg.body_q_camera;
  camera.body_P_camera =
      core::Pose3(core::Rot3::FromQuaternion(q[0], q[1], q[2], q[3]),
                  core::Point3(msg.body_t_camera[0], msg.body_t_camera[1], msg.body_t_camera[2]));
  return CameraInfo{.utime = msg.utime,
                    .robot = msg.robot,
                    .camera_id = msg.camera_id,
                    .from_pose_index = static_cast<std::uint64_t>(msg.from_pose_index),
                    .camera = camera};
}

void ToLcm(const CameraInfo& m, slamd::camera_info_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->camera_id = m.camera_id;
  out->from_pose_index = static_cast<std::int64_t>(m.from_pose_index);
  const Eigen::VectorXd intrinsics =
      std::visit([](const auto& k) { return Eigen::VectorXd(k.vector()); }, m.camera.calibration);
  out->intrinsics.assign(intrinsics.data(), intrinsics.data() + intrinsics.size());
  if (m.camera.stereo()) {
    out->model = C::MODEL_STEREO;
    out->intrinsics.push_back(m.camera.baseline);
  } else {
    out->model = static_cast<std::int8_t>(C::MODEL_PINHOLE + m.camera.calibration.index());
  }
  out->num_intrinsics = static_cast<std::int32_t>(out->intrinsics.size());
  const core::Point3& t = m.camera.body_P_camera.translation();
  const Eigen::Quaterniond q = m.camera.body_P_camera.rotation().ToQuaternion();
  for (int i = 0; i < 3; ++i) out->body_t_camera[i] = t[i];
  out->body_q_camera[0] = q.w();
  out->body_q_camera[1] = q.x();
  out->body_q_camera[2] = q.y();
  out->body_q_camera[3] = q.z();
  out->width = m.camera.width;
  out->height = m.camera.height;
}

const CameraModel* CameraTable::Find(std::uint8_t robot, int camera_id,
                                     std::uint64_t pose_index) const {
  auto it = cameras_.upper_bound({robot, camera_id, pose_index});
  if (it == cameras_.begin()) return nullptr;
  --it;
  const auto& [r, c, from] = it->first;
  return r == robot && c == camera_id ? &it->second : nullptr;
}

const CameraModel* CameraTable::FindExact(std::uint8_t robot, int camera_id,
                                          std::uint64_t from_pose_index) const {
  const auto it = cameras_.find({robot, camera_id, from_pose_index});
  return it == cameras_.end() ? nullptr : &it->second;
}

void CameraTable::Add(std::uint8_t robot, int camera_id, std::uint64_t from_pose_index,
                      const CameraModel& camera) {
  const Id id{robot, camera_id, from_pose_index};
  SLAMD_CHECK(cameras_.emplace(id, camera).second) << "CameraTable::Add: camera added twice";
  added_.push_back(id);
}

void CameraTable::Rollback() {
  for (const Id& id : added_) cameras_.erase(id);
  added_.clear();
}

Outcome CameraInfoSpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const std::optional<std::uint8_t> id = g.FindOrAddRobot(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "camera_info_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  CameraTable& cameras = g.cameras();
  if (const CameraModel* old = cameras.FindExact(*id, m.camera_id, m.from_pose_index)) {
    if (*old == m.camera) return Outcome::kAlreadyHeld;
    *v = {RejectReason::kDuplicate,
          "camera_info_t: robot '" + m.robot + "' camera " + std::to_string(m.camera_id) +
              " from pose " + std::to_string(m.from_pose_index) +
              " has other values already; send a recalibration with the pose it starts at"};
    return Outcome::kRejected;
  }
  cameras.Add(*id, m.camera_id, m.from_pose_index, m.camera);
  return Outcome::kApplied;
}

}  // namespace slamd::server
