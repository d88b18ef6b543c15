#include "core/ba/reconstruction_stream.h"

#include <algorithm>
#include <cmath>
#include <variant>

#include "core/base/param_check.h"
#include "core/factors/prior_factor.h"

namespace slamd::core {

Status ReconstructionStreamParams::Validate() const {
  SLAMD_PARAM_CHECK(ReconstructionStreamParams, min_views, >=, 2);
  SLAMD_PARAM_CHECK(ReconstructionStreamParams, min_registration_points, >=, 3);
  SLAMD_PARAM_CHECK(ReconstructionStreamParams, min_parallax_deg, >=, 0.0);
  SLAMD_PARAM_CHECK(ReconstructionStreamParams, anchor_sigma, >, 0.0);
  SLAMD_PARAM_CHECK(ReconstructionStreamParams, pixel_sigma, >, 0.0);
  return Status::Ok();
}

Result<ReconstructionStream> ReconstructionStream::Create(
    const Reconstruction& r, const ReconstructionStreamParams& params) {
  SLAMD_RETURN_IF_ERROR(params.Validate());
  SLAMD_RETURN_IF_ERROR(r.Validate());
  Result<NoiseModel> pixel = NoiseModel::Isotropic(2, params.pixel_sigma);
  if (!pixel.ok()) return pixel.status();
  return ReconstructionStream(r, params, *pixel);
}

ReconstructionStream::ReconstructionStream(Reconstruction r, ReconstructionStreamParams params,
                                           NoiseModel pixel_noise)
    : r_(std::move(r)),
      params_(params),
      keys_(ReconstructionKeys(r_, params.refine_intrinsics)),
      pixel_noise_(std::move(pixel_noise)) {
  observations_of_image_.resize(r_.images.size());
  observations_of_point_.resize(r_.points.size());
  for (std::size_t o = 0; o < r_.observations.size(); ++o) {
    observations_of_image_[r_.observations[o].image].push_back(static_cast<int>(o));
    observations_of_point_[r_.observations[o].point].push_back(static_cast<int>(o));
  }
  held_.resize(r_.points.size());
  point_in_.assign(r_.points.size(), 0);
  image_in_.assign(r_.images.size(), 0);
  intrinsics_in_.assign(r_.intrinsics.size(), 0);
}

int ReconstructionStream::ViewsNeeded() const {
  // The initial pair's points enter with its two views (nothing else could fix the scale).
  return scale_fixed_ ? params_.min_views : 2;
}

bool ReconstructionStream::Determined(int point, int views, int extra) const {
  const std::vector<int>& held = held_[point];
  const int n = static_cast<int>(held.size()) + (extra >= 0 ? 1 : 0);
  if (n < views) return false;
  const double min_cos = std::cos(params_.min_parallax_deg * M_PI / 180.0);
  const Point3& X = r_.points[point].position;
  const auto ray = [&](int a) {
    const int o = a < static_cast<int>(held.size()) ? held[a] : extra;
    return (X - r_.images[r_.observations[o].image].pose.translation()).normalized();
  };
  for (int a = 0; a < n; ++a) {
    const Vector3 ra = ray(a);
    for (int c = a + 1; c < n; ++c) {
      if (ra.dot(ray(c)) <= min_cos) return true;
    }
  }
  return false;
}

bool ReconstructionStream::Registrable(int image) const {
  if (image == 0) return true;  // the anchor
  int points = 0;
  for (int o : observations_of_image_[image]) {
    const int j = r_.observations[o].point;
    if (point_in_[j] == 1) {
      ++points;
    } else if (!scale_fixed_) {  // the first pair: the points it would determine
      points += Determined(j, ViewsNeeded(), o) ? 1 : 0;
    }
  }
  return points >= params_.min_registration_points;
}

void ReconstructionStream::Register(int i, ReconstructionStep* step) {
  step->images_entered.push_back(i);
  image_in_[i] = 1;
  const int views = ViewsNeeded();  // before a point of this image fixes the scale
  const SfmImage& image = r_.images[i];
  const Key pose = keys_.images[i];
  SLAMD_CHECK(step->values.Insert(pose, image.pose).ok());
  if (i == 0) {
    step->factors.Emplace<PriorFactor<Pose3>>(
        pose, image.pose, NoiseModel::Isotropic(6, params_.anchor_sigma).value());
  }
  if (params_.refine_intrinsics && keys_.calibrations[image.intrinsics] &&
      !intrinsics_in_[image.intrinsics]) {
    intrinsics_in_[image.intrinsics] = 1;
    const Key calibration = *keys_.calibrations[image.intrinsics];
    SLAMD_CHECK(
        step->values.Insert(calibration, CalibrationVariable(r_.intrinsics[image.intrinsics]))
            .ok());
    if (i == 0) {
      std::visit(
          [&](const auto& k) {
            using Cal = std::decay_t<decltype(k)>;
            step->factors.Emplace<PriorFactor<Cal>>(
                calibration, k, NoiseModel::Isotropic(Cal::kDim, params_.anchor_sigma).value());
          },
          r_.intrinsics[image.intrinsics].calibration);
    }
  }
  auto add_observation = [&](int o) {
    AddObservationFactor(r_, r_.observations[o], keys_, pixel_noise_, params_.robust,
                         &step->factors);
    ++step->observations_entered;
  };
  for (int o : observations_of_image_[i]) {
    const int j = r_.observations[o].point;
    if (point_in_[j] == 2) {
      ++dropped_observations_;
      continue;
    }
    if (point_in_[j]) {
      add_observation(o);
      continue;
    }
    held_[j].push_back(o);
    if (!Determined(j, views)) continue;
    point_in_[j] = 1;
    ++points_in_;
    ++step->points_entered;
    const Point3& X = r_.points[j].position;
    SLAMD_CHECK(step->values.Insert(keys_.points[j], X).ok());
    for (int h : held_[j]) add_observation(h);
    held_[j].clear();
    if (!scale_fixed_) {  // the range from image 0
      scale_fixed_ = true;
      scale_point_ = j;
      const Vector3 u = (X - r_.images[0].pose.translation()).normalized();
      const Matrix3 information =
          u * u.transpose() / (params_.anchor_sigma * params_.anchor_sigma) +
          1e-6 * Matrix3::Identity();
      step->factors.Emplace<PriorFactor<Point3>>(keys_.points[j], X,
                                                 NoiseModel::FromInformation(information).value());
    }
  }
}

ReconstructionStep ReconstructionStream::Next() {
  SLAMD_CHECK(next_ < num_steps()) << "ReconstructionStream: no step " << next_;
  ReconstructionStep step;
  held_images_.push_back(next_++);
  // Registering one image puts points in that may let an earlier held one register: the first
  // that can, in order, until none can.
  const auto registrable = [this](int image) { return Registrable(image); };
  for (auto it = std::find_if(held_images_.begin(), held_images_.end(), registrable);
       it != held_images_.end();
       it = std::find_if(held_images_.begin(), held_images_.end(), registrable)) {
    const int image = *it;
    held_images_.erase(it);
    Register(image, &step);
  }
  return step;
}

int ReconstructionStream::held_observations() const {
  int held = 0;
  for (const std::vector<int>& h : held_) held += static_cast<int>(h.size());
  for (int image : held_images_) held += static_cast<int>(observations_of_image_[image].size());
  return held;
}

void ReconstructionStream::Drop(int point) {
  SLAMD_CHECK(Droppable(point)) << "ReconstructionStream::Drop: point " << point
                                << " is not in the graph or fixes the scale";
  point_in_[point] = 2;
  ++dropped_points_;
}

std::vector<int> ReconstructionStream::ImagesSeeing(int point) const {
  std::vector<int> out;
  for (int o : observations_of_point_[point]) {
    const int i = r_.observations[o].image;
    if (image_in_[i]) out.push_back(i);
  }
  return out;
}

int ReconstructionStream::held_images() const { return static_cast<int>(held_images_.size()); }

}  // namespace slamd::core
