// Dataset -> slamd messages (see dataset_messages.h).
#include "clients/slamctl/dataset_messages.h"

#include <type_traits>

#include "core/factors/bearing_range_factor.h"
#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/dataset_stream.h"
#include "server/messages/inbound.h"
#include "server/transport/typed_subscribe.h"

namespace slamd::clients {
namespace {

using core::Pose2;
using core::Pose3;
using server::RelativePose;

// The measured relative pose of a between factor; false for other factors.
bool BetweenOf(const core::Factor& f, RelativePose* measured) {
  const std::optional<core::Variable> z = core::MeasuredRelativePose(f);
  if (!z) return false;
  if (const Pose2* p = std::get_if<Pose2>(&*z)) {
    *measured = *p;
  } else {
    *measured = std::get<Pose3>(*z);
  }
  return true;
}

// z⁻¹ and its first-order noise H Σ Hᵀ (H = ∂z⁻¹/∂z for right perturbations).
core::Result<std::pair<RelativePose, core::NoiseModel>> Reversed(const RelativePose& z,
                                                                 const core::NoiseModel& noise) {
  const Eigen::MatrixXd sigma = noise.Covariance();
  if (const Pose2* p = std::get_if<Pose2>(&z)) {
    core::Matrix3 H;
    const Pose2 inv = p->Inverse(&H);
    const Eigen::MatrixXd cov = H * sigma * H.transpose();
    core::Result<core::NoiseModel> n = core::NoiseModel::FromCovariance(cov);
    if (!n.ok()) return n.status();
    return std::pair<RelativePose, core::NoiseModel>{inv, *n};
  }
  core::Matrix6 H;
  const Pose3 inv = std::get<Pose3>(z).Inverse(&H);
  const Eigen::MatrixXd cov = H * sigma * H.transpose();
  core::Result<core::NoiseModel> n = core::NoiseModel::FromCovariance(cov);
  if (!n.ok()) return n.status();
  return std::pair<RelativePose, core::NoiseModel>{inv, *n};
}

// The landmark message of a pose-landmark factor; false for other factor types.
bool LandmarkOf(const core::Factor& f, std::int64_t utime, const DatasetMessageOptions& options,
                slamd::landmark_observation_t* out) {
  server::LandmarkMeasurement m{.utime = utime,
                                .robot = options.robot,
                                .pose_index = core::KeyIndex(f.keys()[0]),
                                .landmark_id = core::KeyIndex(f.keys()[1]),
                                .kind = server::LandmarkKind::kBearingRange2,
                                .measured = server::BearingRange{},
                                .noise = f.noise_model(),
                                .landmark_namespace = options.shared_landmarks
                                                          ? server::LandmarkNamespace::kMap
                                                          : server::LandmarkNamespace::kRobot};
  // The landmark message kinds by the factor type they become (server/ingest/conversion.h).
  const std::string_view type = f.Name();
  std::vector<double> measured;
  f.EncodeMeasured(&measured);
  if (type == core::BearingRangeFactor::TypeName()) {
    m.measured = server::BearingRange{measured[0], measured[1]};
  } else if (type == core::RelativePointFactor<Pose2, core::Point2>::TypeName()) {
    m.kind = server::LandmarkKind::kRelativePoint2;
    m.measured = core::Point2(measured[0], measured[1]);
  } else if (type == core::RelativePointFactor<Pose3, core::Point3>::TypeName()) {
    m.kind = server::LandmarkKind::kRelativePoint3;
    m.measured = core::Point3(measured[0], measured[1], measured[2]);
  } else {
    return false;
  }
  server::ToLcm(m, out);
  return true;
}

using PriorValue = decltype(server::PriorMeasurement::measured);
PriorValue PosePriorValue(const core::Variable& pose) {
  if (const Pose2* p = std::get_if<Pose2>(&pose)) return *p;
  return std::get<Pose3>(pose);
}

}  // namespace

bool IsValidRobotName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) return false;
  }
  return true;
}

core::Result<std::vector<StepMessages>> MakeDatasetMessages(const core::Dataset& dataset,
                                                            const DatasetMessageOptions& options) {
  if (!IsValidRobotName(options.robot)) {
    return core::InvalidArgument("robot name '" + options.robot +
                                 "': needs 1..64 chars of [A-Za-z0-9_.-]");
  }
  if (!(options.anchor_sigma >= 0.0)) {
    return core::InvalidArgument("anchor sigma " + std::to_string(options.anchor_sigma) +
                                 " must be >= 0");
  }
  if (options.utime_start_us < 0 || options.utime_step_us < 0) {
    return core::InvalidArgument("utime start and step must be >= 0");
  }
  const std::vector<core::DatasetStep> steps = core::MakeIncrementalSteps(dataset);
  std::vector<StepMessages> out;
  out.reserve(steps.size());
  for (size_t k = 0; k < steps.size(); ++k) {
    const core::DatasetStep& step = steps[k];
    const std::int64_t utime =
        options.utime_start_us + static_cast<std::int64_t>(k) * options.utime_step_us;
    StepMessages sm;
    sm.pose_index = core::KeyIndex(step.pose);
    // 1. The anchoring prior of the first pose.
    if (k == 0 && options.anchor_sigma > 0.0) {
      const bool is2d = std::holds_alternative<Pose2>(step.initial);
      core::Result<core::NoiseModel> noise =
          core::NoiseModel::Isotropic(is2d ? 3 : 6, options.anchor_sigma);
      if (!noise.ok()) return noise.status();
      server::PriorMeasurement prior{
          .utime = utime,
          .robot = options.robot,
          .pose_index = sm.pose_index,
          .kind = is2d ? server::PriorKind::kPose2 : server::PriorKind::kPose3,
          .measured = PosePriorValue(step.initial),
          .noise = *noise};
      slamd::prior_t msg;
      server::ToLcm(prior, &msg);
      sm.messages.emplace_back(std::move(msg));
      sm.introduces_pose = true;
    }
    // 2. The odometry, always from the earlier pose to the new one.
    if (step.odometry) {
      RelativePose z;
      if (!BetweenOf(*step.odometry, &z)) {
        return core::InvalidArgument("step " + std::to_string(k) + ": odometry factor " +
                                     step.odometry->Name() + " is not a between factor");
      }
      core::NoiseModel noise = step.odometry->noise_model();
      if (step.odometry->keys()[0] == step.pose) {  // written (pose, from): send it reversed
        auto reversed = Reversed(z, noise);
        if (!reversed.ok()) return reversed.status();
        z = reversed->first;
        noise = reversed->second;
      }
      server::OdometryMeasurement odo{.utime = utime,
                                      .robot = options.robot,
                                      .from_index = core::KeyIndex(step.odometry_from),
                                      .to_index = sm.pose_index,
                                      .measured = z,
                                      .noise = noise};
      slamd::odometry_t msg;
      server::ToLcm(odo, &msg);
      sm.messages.emplace_back(std::move(msg));
      sm.introduces_pose = true;
    }
    // 3. Every other factor of the step, in graph order.
    for (const core::FactorPtr& f : step.factors) {
      if (f == step.odometry) continue;
      RelativePose z;
      if (BetweenOf(*f, &z)) {
        server::LoopClosureMeasurement lc{.utime = utime,
                                          .robot_a = options.robot,
                                          .pose_a = core::KeyIndex(f->keys()[0]),
                                          .robot_b = options.robot,
                                          .pose_b = core::KeyIndex(f->keys()[1]),
                                          .measured = z,
                                          .noise = f->noise_model(),
                                          .robust = f->robust_kernel()};
        slamd::loop_closure_t msg;
        server::ToLcm(lc, &msg);
        sm.messages.emplace_back(std::move(msg));
        continue;
      }
      slamd::landmark_observation_t msg;
      if (!LandmarkOf(*f, utime, options, &msg)) {
        return core::InvalidArgument("step " + std::to_string(k) + " (" +
                                     core::KeyToString(step.pose) + "): factor " + f->Name() +
                                     " has no slamd message form");
      }
      sm.messages.emplace_back(std::move(msg));
    }
    out.push_back(std::move(sm));
  }
  return out;
}

std::size_t CountMessages(const std::vector<StepMessages>& steps) {
  std::size_t n = 0;
  for (const StepMessages& s : steps) n += s.messages.size();
  return n;
}

std::string ChannelOf(const RobotMessage& message, const server::ChannelNames& channels) {
  return std::visit(
      [&](const auto& m) { return channels.Inbound<server::SpecOfLcm<decltype(m)>>(); }, message);
}

core::Status EncodeMessage(const RobotMessage& message, std::vector<std::uint8_t>* bytes) {
  return std::visit([&](const auto& m) { return server::Encode(m, bytes); }, message);
}

}  // namespace slamd::clients
