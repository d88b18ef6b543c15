#include "core/sfm/reconstruction.h"

#include <string>

namespace slamd::core {
namespace {

bool Finite(const Calibration& c) {
  return std::visit([](const auto& k) { return k.vector().allFinite(); }, c);
}

}  // namespace

Status Reconstruction::Validate() const {
  const int num_intrinsics = static_cast<int>(intrinsics.size());
  const int num_images = static_cast<int>(images.size());
  const int num_points = static_cast<int>(points.size());
  for (int k = 0; k < num_intrinsics; ++k) {
    if (!Finite(intrinsics[k].calibration) || !intrinsics[k].principal_point.allFinite()) {
      return InvalidArgument("intrinsics " + std::to_string(k) + ": a parameter is not finite");
    }
  }
  for (int i = 0; i < num_images; ++i) {
    const SfmImage& image = images[i];
    if (image.intrinsics < 0 || image.intrinsics >= num_intrinsics) {
      return InvalidArgument("image " + std::to_string(i) + ": intrinsics index " +
                             std::to_string(image.intrinsics) + " out of range [0, " +
                             std::to_string(num_intrinsics) + ")");
    }
    if (!image.pose.matrix().allFinite()) {
      return InvalidArgument("image " + std::to_string(i) + ": pose is not finite");
    }
  }
  for (int j = 0; j < num_points; ++j) {
    if (!points[j].position.allFinite()) {
      return InvalidArgument("point " + std::to_string(j) + ": position is not finite");
    }
  }
  for (size_t o = 0; o < observations.size(); ++o) {
    const SfmObservation& obs = observations[o];
    if (obs.image < 0 || obs.image >= num_images || obs.point < 0 || obs.point >= num_points) {
      return InvalidArgument("observation " + std::to_string(o) + ": image " +
                             std::to_string(obs.image) + " / point " + std::to_string(obs.point) +
                             " out of range (" + std::to_string(num_images) + " images, " +
                             std::to_string(num_points) + " points)");
    }
    if (!obs.uv.allFinite()) {
      return InvalidArgument("observation " + std::to_string(o) + ": pixel is not finite");
    }
  }
  return Status::Ok();
}

}  // namespace slamd::core
