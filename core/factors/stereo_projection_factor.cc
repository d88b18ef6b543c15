#include "core/factors/stereo_projection_factor.h"

#include <cmath>

namespace slamd::core {

Result<FactorPtr> StereoProjectionFactor::Decode(const FactorRecord& r, NoiseModel noise) {
  Result<internal::CameraRecord> c =
      internal::SplitCameraRecord(r, 3, 6, "(uL, uR, v), (fx, fy, s, u0, v0, baseline) (6)");
  if (!c.ok()) return c.status();
  Result<Variable> pinhole = DecodeVariable(kVariableType<Cal3_S2>, c->calibration.first(5));
  const double baseline = c->calibration[5];
  if (!pinhole.ok()) return InvalidArgument("calibration: " + pinhole.status().message());
  if (!std::isfinite(baseline)) return InvalidArgument("calibration: the baseline is not finite");
  const Cal3_S2Stereo K(std::get<Cal3_S2>(*pinhole), baseline);
  return FactorPtr(std::make_shared<const StereoProjectionFactor>(
      r.keys[0], r.keys[1], Eigen::Map<const Vector3>(c->measured.data()), K, std::move(noise),
      r.robust, c->mount.body_P_camera()));
}

void StereoProjectionFactor::EncodeMeasured(std::vector<double>* out) const {
  out->insert(out->end(), measured_.data(), measured_.data() + 3);
  EncodeVariable(K_.K(), out);
  out->push_back(K_.baseline());
  mount_.Encode(out);
}

std::optional<Variable> StereoProjectionFactor::Predict(int known,
                                                        const Variable& known_value) const {
  if (known != 0) return std::nullopt;
  SLAMD_CHECK(std::holds_alternative<Pose3>(known_value))
      << TypeName() << ": the known value has the wrong type";
  const Pose3 camera = mount_.CameraPose(std::get<Pose3>(known_value));
  return camera.TransformFrom(BackprojectStereo(K_, measured_));
}

}  // namespace slamd::core
