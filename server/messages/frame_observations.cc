#include "server/messages/frame_observations.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <variant>

#include "core/factors/projection_factor.h"
#include "core/factors/stereo_projection_factor.h"
#include "server/ingest/field_checks.h"
#include "server/messages/landmark_tracks.h"

namespace slamd::server {
namespace {

using F = ::slamd::frame_observations_t;
using core::Key;
using internal::CheckCount;
using internal::CheckCovariance;
using internal::CheckFinite;
using internal::CheckIndex;
using internal::CheckKindRange;
using internal::CheckMagnitude;
using internal::CheckName;
using internal::CheckRobustKernel;
using internal::CheckUtime;
using internal::FormatNumber;
using internal::Reject;

int Dim(bool stereo) { return stereo ? 3 : 2; }

std::string Indexed(const char* field, std::size_t i) {
  return std::string("frame_observations_t.") + field + "[" + std::to_string(i) + "]";
}

// The pixel noise of feature k (sizes and finiteness checked).
Verdict FeatureNoise(const F& msg, int k, int dim, const Limits& limits,
                     std::optional<core::NoiseModel>* noise) {
  if (msg.num_covariance > 0) {
    const std::span<const double> c(msg.covariance.data() + k * dim * dim, dim * dim);
    return CheckCovariance(Indexed("covariance", k * dim * dim), c, dim, limits, noise);
  }
  const double sigma = msg.sigmas[msg.num_sigmas == 1 ? 0 : k];
  if (!(sigma > 0.0) || !(sigma * sigma >= limits.min_variance) ||
      !(sigma <= limits.max_abs_value)) {
    return Reject(RejectReason::kBadMeasurement, Indexed("sigmas", msg.num_sigmas == 1 ? 0 : k),
                  "sigma " + FormatNumber(sigma) + " px is outside [" +
                      FormatNumber(std::sqrt(limits.min_variance)) + ", " +
                      FormatNumber(limits.max_abs_value) + "]");
  }
  if (noise) *noise = core::NoiseModel::Isotropic(dim, sigma).value();
  return {};
}

// Validate, also building the features' noise models when `features` is given.
Verdict Check(const F& msg, const Limits& limits, std::vector<FrameFeature>* features,
              core::RobustKernel* robust) {
  SLAMD_RETURN_IF_REJECTED(CheckUtime("frame_observations_t.utime", msg.utime));
  SLAMD_RETURN_IF_REJECTED(
      CheckName("frame_observations_t.robot", msg.robot, limits.max_robot_name_length));
  SLAMD_RETURN_IF_REJECTED(CheckIndex("frame_observations_t.pose_index", msg.pose_index));
  if (msg.camera_id < 0 || msg.camera_id > 255) {
    return Reject(RejectReason::kIndexOutOfRange, "frame_observations_t.camera_id",
                  std::to_string(msg.camera_id) + " is outside 0..255");
  }
  SLAMD_RETURN_IF_REJECTED(CheckKindRange("frame_observations_t.kind", msg.kind, F::KIND_MONO,
                                          F::KIND_STEREO, "1 (mono), 2 (stereo)"));
  SLAMD_RETURN_IF_REJECTED(CheckKindRange("frame_observations_t.landmark_namespace",
                                          msg.landmark_namespace, F::NAMESPACE_ROBOT,
                                          F::NAMESPACE_MAP, "0 (robot), 1 (map)"));
  const int n = msg.num_features;
  if (n < 1 || n > kMaxFrameFeatures) {
    return Reject(RejectReason::kTooManyElements, "frame_observations_t.num_features",
                  std::to_string(n) + " is outside 1.." + std::to_string(kMaxFrameFeatures));
  }
  const int dim = Dim(msg.kind == F::KIND_STEREO);
  const char* layout = dim == 3 ? "kind 2 (stereo): 3 per feature" : "kind 1 (mono): 2 per feature";
  SLAMD_RETURN_IF_REJECTED(
      CheckCount("frame_observations_t.num_features", n, msg.landmark_ids.size(), -1, ""));
  SLAMD_RETURN_IF_REJECTED(CheckCount("frame_observations_t.num_values", msg.num_values,
                                      msg.values.size(), n * dim, layout));
  const bool per_covariance = msg.num_covariance > 0;
  if (per_covariance ? msg.num_sigmas != 0 : (msg.num_sigmas != 1 && msg.num_sigmas != n)) {
    return Reject(RejectReason::kSizeMismatch, "frame_observations_t.num_sigmas",
                  std::to_string(msg.num_sigmas) +
                      ": one sigma, one per feature, or none with a covariance per feature");
  }
  SLAMD_RETURN_IF_REJECTED(
      CheckCount("frame_observations_t.num_sigmas", msg.num_sigmas, msg.sigmas.size(), -1, ""));
  SLAMD_RETURN_IF_REJECTED(CheckCount("frame_observations_t.num_covariance", msg.num_covariance,
                                      msg.covariance.size(), per_covariance ? n * dim * dim : 0,
                                      "a covariance per feature"));
  for (int k = 0; k < n; ++k) {
    SLAMD_RETURN_IF_REJECTED(CheckIndex(Indexed("landmark_ids", k), msg.landmark_ids[k]));
  }
  std::vector<std::int64_t> ids = msg.landmark_ids;
  std::sort(ids.begin(), ids.end());
  if (const auto twice = std::adjacent_find(ids.begin(), ids.end()); twice != ids.end()) {
    const auto first = std::find(msg.landmark_ids.begin(), msg.landmark_ids.end(), *twice);
    const auto second = std::find(first + 1, msg.landmark_ids.end(), *twice);
    return Reject(RejectReason::kDuplicate,
                  Indexed("landmark_ids", second - msg.landmark_ids.begin()),
                  "landmark " + std::to_string(*twice) + " is also feature " +
                      std::to_string(first - msg.landmark_ids.begin()));
  }
  SLAMD_RETURN_IF_REJECTED(CheckFinite("frame_observations_t.values", msg.values));
  SLAMD_RETURN_IF_REJECTED(
      CheckMagnitude("frame_observations_t.values", msg.values, limits.max_abs_value));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("frame_observations_t.sigmas", msg.sigmas));
  SLAMD_RETURN_IF_REJECTED(CheckFinite("frame_observations_t.covariance", msg.covariance));
  if (dim == 3) {
    for (int k = 0; k < n; ++k) {
      if (msg.values[3 * k + 1] > msg.values[3 * k]) {
        return Reject(RejectReason::kBadMeasurement, Indexed("values", 3 * k + 1),
                      "u_right " + FormatNumber(msg.values[3 * k + 1]) + " exceeds u_left " +
                          FormatNumber(msg.values[3 * k]) +
                          " (negative disparity: behind the cameras)");
      }
    }
  }
  SLAMD_RETURN_IF_REJECTED(CheckRobustKernel(
      "frame_observations_t.robust_kernel", "frame_observations_t.robust_parameter",
      msg.robust_kernel, msg.robust_parameter, limits, robust));
  for (int k = 0; k < n; ++k) {
    std::optional<core::NoiseModel> noise;
    SLAMD_RETURN_IF_REJECTED(FeatureNoise(msg, k, dim, limits, features ? &noise : nullptr));
    if (!features) continue;
    const double* v = msg.values.data() + dim * k;
    features->push_back({.landmark_id = static_cast<std::uint64_t>(msg.landmark_ids[k]),
                         .uv = dim == 3 ? core::Vector2(v[0], v[2]) : core::Vector2(v[0], v[1]),
                         .u_right = dim == 3 ? v[1] : 0.0,
                         .noise = std::move(*noise),
                         .index = k});
  }
  return {};
}

// The view of feature f from the camera at camera_pose (T_wc).
core::LandmarkView View(const core::Pose3& camera_pose, const CameraModel& camera,
                        const FrameFeature& f, bool stereo) {
  return {.camera_pose = camera_pose,
          .calibration = camera.calibration,
          .uv = f.uv,
          .baseline = stereo ? camera.baseline : 0.0,
          .u_right = f.u_right};
}

// A rejection of feature f of m: "frame_observations_t.values[2k]: landmark 17: <what>".
Verdict FeatureReject(const FrameObservations& m, const FrameFeature& f, RejectReason reason,
                      const std::string& what) {
  return {reason, Indexed("values", static_cast<std::size_t>(Dim(m.stereo) * f.index)) +
                      ": landmark " + std::to_string(f.landmark_id) + ": " + what};
}

// When the track of `landmark` now determines it: the landmark (at its triangulated position) and
// a factor for each observation of the track; otherwise the reason goes to the track.
void TryToInitialize(Key landmark, GraphBuilder& g) {
  const LandmarkTracks::Track& track = *g.tracks().Find(landmark);
  std::vector<core::LandmarkView> views;
  std::vector<Key> poses;
  std::vector<const CameraModel*> cameras;
  for (const FrameObservations& o : track.observations) {
    const std::uint8_t robot = g.FindRobot(o.robot).value();
    poses.push_back(core::MakeKey('x', o.pose_index, robot));
    cameras.push_back(g.cameras().Find(robot, o.camera_id, o.pose_index));
    SLAMD_CHECK(cameras.back() != nullptr) << "a track's observation lost its camera";
    const core::Pose3 body = std::get<core::Pose3>(g.Estimate(poses.back()));
    views.push_back(
        View(body * cameras.back()->body_P_camera, *cameras.back(), o.features[0], o.stereo));
  }
  const core::Result<core::Point3> X =
      core::InitializeLandmark(views, g.policy().landmark_initialization);
  if (!X.ok()) {
    g.tracks().SetReason(landmark, X.status().message());
    return;
  }
  bool any = false;
  for (std::size_t i = 0; i < track.observations.size(); ++i) {
    const FrameObservations& o = track.observations[i];
    g.FirstTime({FrameObservationsSpec::kIdentity, poses[i], landmark, o.camera_id});
    Verdict v;
    const Outcome outcome = g.AddMeasured(
        FrameObservationsSpec::Factor(o, o.features[0], *cameras[i], poses[i], landmark), poses[i],
        FrameObservationsSpec::kType, &v);
    any = any || outcome == Outcome::kApplied;
  }
  if (any) g.AddVariable(landmark, *X);
  g.tracks().Erase(landmark);
}

}  // namespace

Verdict Validate(const slamd::frame_observations_t& msg, const Limits& limits) {
  return Check(msg, limits, nullptr, nullptr);
}

Checked<FrameObservations> Convert(const slamd::frame_observations_t& msg, const Limits& limits) {
  std::vector<FrameFeature> features;
  features.reserve(std::max(0, msg.num_features));
  core::RobustKernel robust;
  Verdict verdict = Check(msg, limits, &features, &robust);
  if (!verdict.ok()) return verdict;
  return FrameObservations{
      .utime = msg.utime,
      .robot = msg.robot,
      .pose_index = static_cast<std::uint64_t>(msg.pose_index),
      .camera_id = msg.camera_id,
      .stereo = msg.kind == F::KIND_STEREO,
      .landmark_namespace = static_cast<LandmarkNamespace>(msg.landmark_namespace),
      .features = std::move(features),
      .robust = robust};
}

void ToLcm(const FrameObservations& m, slamd::frame_observations_t* out) {
  out->utime = m.utime;
  out->robot = m.robot;
  out->pose_index = static_cast<std::int64_t>(m.pose_index);
  out->camera_id = m.camera_id;
  out->kind = m.stereo ? F::KIND_STEREO : F::KIND_MONO;
  out->landmark_namespace = static_cast<std::int8_t>(m.landmark_namespace);
  const bool isotropic = std::all_of(m.features.begin(), m.features.end(), [](const auto& f) {
    return f.noise.kind() == core::NoiseModel::Kind::kIsotropic;
  });
  out->landmark_ids.clear();
  out->values.clear();
  out->sigmas.clear();
  out->covariance.clear();
  for (const FrameFeature& f : m.features) {
    out->landmark_ids.push_back(static_cast<std::int64_t>(f.landmark_id));
    out->values.push_back(f.uv.x());
    if (m.stereo) out->values.push_back(f.u_right);
    out->values.push_back(f.uv.y());
    if (isotropic) {
      out->sigmas.push_back(f.noise.Sigmas()[0]);
    } else {
      const Eigen::MatrixXd c = f.noise.Covariance();
      for (int r = 0; r < c.rows(); ++r) {
        for (int col = 0; col < c.cols(); ++col) out->covariance.push_back(c(r, col));
      }
    }
  }
  out->num_features = static_cast<std::int32_t>(m.features.size());
  out->num_values = static_cast<std::int32_t>(out->values.size());
  out->num_sigmas = static_cast<std::int32_t>(out->sigmas.size());
  out->num_covariance = static_cast<std::int32_t>(out->covariance.size());
  out->robust_kernel = m.robust.is_none() ? "" : core::RobustKernel::KindName(m.robust.kind());
  out->robust_parameter = m.robust.parameter();
}

FrameObservations OneFeature(const FrameObservations& m, std::size_t k) {
  FrameObservations one{.utime = m.utime,
                        .robot = m.robot,
                        .pose_index = m.pose_index,
                        .camera_id = m.camera_id,
                        .stereo = m.stereo,
                        .landmark_namespace = m.landmark_namespace,
                        .features = {m.features[k]},
                        .robust = m.robust};
  return one;
}

core::FactorPtr FrameObservationsSpec::Factor(const Value& m, const FrameFeature& f,
                                              const CameraModel& camera, Key pose, Key landmark) {
  if (m.stereo) {
    return std::make_shared<core::StereoProjectionFactor>(
        pose, landmark, core::Vector3(f.uv.x(), f.u_right, f.uv.y()),
        core::Cal3_S2Stereo(std::get<core::Cal3_S2>(camera.calibration), camera.baseline), f.noise,
        m.robust, camera.body_P_camera);
  }
  return std::visit(
      [&](const auto& K) -> core::FactorPtr {
        using Cal = std::decay_t<decltype(K)>;
        return std::make_shared<core::ProjectionFactor<Cal>>(pose, landmark, f.uv, K, f.noise,
                                                             m.robust, camera.body_P_camera);
      },
      camera.calibration);
}

Outcome FrameObservationsSpec::Apply(const Value& m, GraphBuilder& g, Verdict* v) {
  const std::optional<std::uint8_t> id = g.FindOrAddRobot(m.robot);
  if (!id) {
    *v = {RejectReason::kTooManyElements, "frame_observations_t.robot: more than 255 robots"};
    return Outcome::kRejected;
  }
  const Key pose = core::MakeKey('x', m.pose_index, *id);
  const CameraModel* camera = g.cameras().Find(*id, m.camera_id, m.pose_index);
  if (!g.Known(pose) || camera == nullptr) return Outcome::kHeld;
  const core::Variable x = g.Estimate(pose);
  if (!std::holds_alternative<core::Pose3>(x)) {
    *v = {RejectReason::kBadMeasurement,
          "frame_observations_t.pose_index: " + PoseName(m.robot, m.pose_index) +
              " is a 2D pose; camera frames need 3D poses"};
    return Outcome::kRejected;
  }
  if (m.stereo && !camera->stereo()) {
    *v = {RejectReason::kBadMeasurement, "frame_observations_t.kind: stereo features, but camera " +
                                             std::to_string(m.camera_id) + " of robot '" + m.robot +
                                             "' is not a stereo pair (camera_info_t.model)"};
    return Outcome::kRejected;
  }
  const core::Pose3 camera_pose = std::get<core::Pose3>(x) * camera->body_P_camera;
  const double max_error = g.policy().max_landmark_error_px;
  int accepted = 0, already = 0;
  std::vector<Verdict> rejected;
  for (std::size_t k = 0; k < m.features.size(); ++k) {
    const FrameFeature& f = m.features[k];
    auto reject = [&](RejectReason reason, const std::string& what) {
      rejected.push_back(FeatureReject(m, f, reason, what));
    };
    if (!camera->Inside(f.uv.x(), f.uv.y()) || (m.stereo && !camera->Inside(f.u_right, 0.0))) {
      reject(RejectReason::kBadMeasurement,
             "the pixel is outside camera " + std::to_string(m.camera_id) + "'s " +
                 std::to_string(camera->width) + "x" + std::to_string(camera->height) + " image");
      continue;
    }
    const Key landmark = LandmarkKey(m.landmark_namespace, f.landmark_id, *id);
    if (g.Known(landmark)) {
      const core::Variable l = g.Estimate(landmark);
      if (!std::holds_alternative<core::Point3>(l)) {
        reject(RejectReason::kBadMeasurement, "a 2D landmark; camera features need 3D ones");
        continue;
      }
      double depth = 0.0;
      const double error = std::sqrt(core::SquaredReprojectionError(
          View(camera_pose, *camera, f, m.stereo), std::get<core::Point3>(l), &depth));
      if (!(depth > 0.0)) {
        reject(RejectReason::kBadMeasurement,
               "behind the camera at the current estimate (depth " + FormatNumber(depth) + " m)");
        continue;
      }
      if (!(error <= max_error)) {
        reject(RejectReason::kBadMeasurement,
               "the landmark projects " + FormatNumber(error) +
                   " px from the pixel (estimator.max_landmark_error_px = " +
                   FormatNumber(max_error) + ")");
        continue;
      }
      g.FirstTime({kIdentity, pose, landmark, m.camera_id});
      Verdict fv;
      switch (g.AddMeasured(Factor(m, f, *camera, pose, landmark), pose, kType, &fv)) {
        case Outcome::kApplied:
          ++accepted;
          break;
        case Outcome::kAlreadyHeld:
          ++already;
          break;
        default:
          rejected.push_back(FeatureReject(m, f, fv.reason, fv.message));
      }
      continue;
    }
    // Not in the graph: the landmark's track, unless it holds this observation already.
    if (const LandmarkTracks::Track* track = g.tracks().Find(landmark)) {
      const auto same =
          std::find_if(track->observations.begin(), track->observations.end(), [&](const auto& o) {
            return o.robot == m.robot && o.pose_index == m.pose_index && o.camera_id == m.camera_id;
          });
      if (same != track->observations.end()) {
        const FrameFeature& held = same->features[0];
        if (held.uv == f.uv && held.u_right == f.u_right && held.noise.Equals(f.noise, 0.0)) {
          ++already;
        } else {
          reject(RejectReason::kDuplicate,
                 "a different observation from this pose and camera is held already");
        }
        continue;
      }
    }
    g.tracks().Add(landmark, OneFeature(m, k));
    ++accepted;
    TryToInitialize(landmark, g);
  }
  if (accepted == 0 && already == 0) {
    *v = rejected.front();
    for (std::size_t i = 1; i < rejected.size(); ++i) g.RejectPart(rejected[i]);
    return Outcome::kRejected;
  }
  for (Verdict& r : rejected) g.RejectPart(std::move(r));
  if (accepted == 0) return Outcome::kAlreadyHeld;
  g.Touch(*id);
  return Outcome::kApplied;
}

}  // namespace slamd::server
