// Monocular projection factors: a landmark (Point3, world frame) observed at pixel (u, v) by a
// camera (core/geometry/camera.h: +z forward, x right, y down) mounted on a body whose pose
// (Pose3, T_wb) is the variable; the camera sits at T_wb·body_P_camera (camera_mount.h; identity
// by default, when the pose is the camera's own).
//
//   ProjectionFactor<Cal>                 on (pose, landmark), calibration K fixed
//   SelfCalibratingProjectionFactor<Cal>  on (pose, landmark, calibration): K is a variable
//
// for Cal = Cal3_S2, Cal3DS2, Cal3Bundler. Error: e = Project(T_wb·body_P_camera, K, landmark).uv
// − measured, in pixels (the noise model's units). Jacobians: right perturbation of the pose,
// addition for the landmark and the calibration (camera.h).
//
// Cheirality: a landmark behind the camera still gives the formula's error and Jacobians
// (camera.h), so the cost does not go flat; InFront tells callers (outlier rejection, bundle
// adjustment bookkeeping) whether the landmark is in front at given values.
//
// Predict: nothing in either direction: one pixel is a ray, not a point (no depth), and a
// landmark does not place the pose. Landmarks are initialised by triangulation (core/sfm).
//
// Encoded as (u, v), then K's parameters (ProjectionFactor only), then body_P_camera (12
// numbers, camera_mount.h). Immutable, like every factor.
#pragma once

#include <string>

#include "core/factors/camera_mount.h"
#include "core/factors/factor.h"

namespace slamd::core {

template <typename Cal>
class ProjectionFactor : public TypedFactor<ProjectionFactor<Cal>, 2, Pose3, Point3> {
  using Base = TypedFactor<ProjectionFactor<Cal>, 2, Pose3, Point3>;

 public:
  // "Projection" + the calibration's name, e.g. "ProjectionCal3DS2".
  static const char* TypeName() {
    static const std::string name = std::string("Projection") + VariableTraits<Cal>::kName;
    return name.c_str();
  }

  ProjectionFactor(Key pose, Key landmark, const Vector2& measured, const Cal& K, NoiseModel noise,
                   RobustKernel robust = {}, const Pose3& body_P_camera = Pose3())
      : Base({pose, landmark}, std::move(noise), robust),
        measured_(measured),
        K_(K),
        mount_(body_P_camera) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    static const std::string layout = std::string("(u, v), ") + VariableTraits<Cal>::kName + " (" +
                                      std::to_string(Cal::kDim) + ")";
    Result<internal::CameraRecord> c = internal::SplitCameraRecord(r, 2, Cal::kDim, layout.c_str());
    if (!c.ok()) return c.status();
    Result<Variable> K = DecodeVariable(kVariableType<Cal>, c->calibration);
    if (!K.ok()) return InvalidArgument("calibration: " + K.status().message());
    return FactorPtr(std::make_shared<const ProjectionFactor>(
        r.keys[0], r.keys[1], Eigen::Map<const Vector2>(c->measured.data()), std::get<Cal>(*K),
        std::move(noise), r.robust, c->mount.body_P_camera()));
  }

  const Vector2& measured() const { return measured_; }
  const Cal& calibration() const { return K_; }
  const Pose3& body_P_camera() const { return mount_.body_P_camera(); }
  void EncodeMeasured(std::vector<double>* out) const override {
    out->insert(out->end(), measured_.data(), measured_.data() + 2);
    EncodeVariable(K_, out);
    mount_.Encode(out);
  }
  // Whether the landmark is in front of the camera at `values` (which must hold both keys).
  bool InFront(const Values& values) const {
    return mount_.Depth(values.At<Pose3>(this->keys()[0]), values.At<Point3>(this->keys()[1])) >
           0.0;
  }

  typename Base::ErrorVector Evaluate(const Pose3& pose, const Point3& landmark, Matrix26* H_pose,
                                      Matrix23* H_landmark) const {
    return mount_.Project(pose, K_, landmark, H_pose, H_landmark).uv - measured_;
  }

 private:
  Vector2 measured_;
  Cal K_;
  CameraMount mount_;
};

template <typename Cal>
class SelfCalibratingProjectionFactor
    : public TypedFactor<SelfCalibratingProjectionFactor<Cal>, 2, Pose3, Point3, Cal> {
  using Base = TypedFactor<SelfCalibratingProjectionFactor<Cal>, 2, Pose3, Point3, Cal>;

 public:
  // "SelfCalProjection" + the calibration's name, e.g. "SelfCalProjectionCal3Bundler".
  static const char* TypeName() {
    static const std::string name = std::string("SelfCalProjection") + VariableTraits<Cal>::kName;
    return name.c_str();
  }

  SelfCalibratingProjectionFactor(Key pose, Key landmark, Key calibration, const Vector2& measured,
                                  NoiseModel noise, RobustKernel robust = {},
                                  const Pose3& body_P_camera = Pose3())
      : Base({pose, landmark, calibration}, std::move(noise), robust),
        measured_(measured),
        mount_(body_P_camera) {}
  static Result<FactorPtr> Decode(const FactorRecord& r, NoiseModel noise) {
    Result<internal::CameraRecord> c = internal::SplitCameraRecord(r, 2, 0, "(u, v)");
    if (!c.ok()) return c.status();
    return FactorPtr(std::make_shared<const SelfCalibratingProjectionFactor>(
        r.keys[0], r.keys[1], r.keys[2], Eigen::Map<const Vector2>(c->measured.data()),
        std::move(noise), r.robust, c->mount.body_P_camera()));
  }

  const Vector2& measured() const { return measured_; }
  const Pose3& body_P_camera() const { return mount_.body_P_camera(); }
  void EncodeMeasured(std::vector<double>* out) const override {
    out->insert(out->end(), measured_.data(), measured_.data() + 2);
    mount_.Encode(out);
  }
  // Whether the landmark is in front of the camera at `values` (which must hold the pose and
  // the landmark; the calibration does not matter).
  bool InFront(const Values& values) const {
    return mount_.Depth(values.At<Pose3>(this->keys()[0]), values.At<Point3>(this->keys()[1])) >
           0.0;
  }

  typename Base::ErrorVector Evaluate(const Pose3& pose, const Point3& landmark, const Cal& K,
                                      Matrix26* H_pose, Matrix23* H_landmark,
                                      CalibrationJacobian<Cal>* H_cal) const {
    return mount_.Project(pose, K, landmark, H_pose, H_landmark, H_cal).uv - measured_;
  }

 private:
  Vector2 measured_;
  CameraMount mount_;
};

}  // namespace slamd::core
