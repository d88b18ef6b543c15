#include "core/factors/camera_mount.h"

#include <cmath>
#include <string>

#include "core/variables/variable.h"

namespace slamd::core {

StereoProjection CameraMount::ProjectStereo(const Pose3& body_pose, const Cal3_S2Stereo& K,
                                            const Point3& p_w, Matrix36* H_pose,
                                            Matrix3* H_point) const {
  Matrix36 H_camera;
  const StereoProjection p =
      core::ProjectStereo(CameraPose(body_pose), K, p_w, H_pose ? &H_camera : nullptr, H_point);
  if (H_pose) *H_pose = H_camera * camera_from_body_;
  return p;
}

void CameraMount::Encode(std::vector<double>* out) const { EncodeVariable(body_P_camera_, out); }

namespace internal {

Result<CameraRecord> SplitCameraRecord(const FactorRecord& r, int measured_size,
                                       int calibration_size, const char* layout) {
  const int pose_size = EncodedSize(kVariableType<Pose3>);
  const int expected = measured_size + calibration_size + pose_size;
  const std::span<const double> all(r.measured);
  if (static_cast<int>(all.size()) != expected) {
    return InvalidArgument(std::string("measured: ") + layout + " and body_P_camera (" +
                           std::to_string(pose_size) + ") are " + std::to_string(expected) +
                           " numbers, not " + std::to_string(all.size()));
  }
  const std::span<const double> measured = all.first(measured_size);
  for (double m : measured) {
    if (!std::isfinite(m)) return InvalidArgument("measured: a measurement is not finite");
  }
  Result<Variable> mount = DecodeVariable(kVariableType<Pose3>, all.last(pose_size));
  if (!mount.ok()) return InvalidArgument("body_P_camera: " + mount.status().message());
  return CameraRecord{.measured = measured,
                      .calibration = all.subspan(measured_size, calibration_size),
                      .mount = CameraMount(std::get<Pose3>(*mount))};
}

}  // namespace internal
}  // namespace slamd::core
