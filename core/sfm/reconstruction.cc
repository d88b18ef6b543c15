#include "core/sfm/reconstruction.h"

#include <string>
#include <type_traits>
#include <variant>

namespace slamd::core {
namespace {

bool Finite(const Calibration& c) {
  return std::visit([](const auto& k) { return k.vector().allFinite(); }, c);
}

}  // namespace

Eigen::MatrixXd CalibrationBasis(const SfmIntrinsics& k, bool principal_point) {
  const int dim =
      std::visit([](const auto& c) { return std::decay_t<decltype(c)>::kDim; }, k.calibration);
  Eigen::MatrixXd basis = Eigen::MatrixXd::Identity(dim, dim);
  const bool pinhole = std::holds_alternative<Cal3_S2>(k.calibration);
  const bool opencv = std::holds_alternative<Cal3DS2>(k.calibration);
  // Cal3_S2's parameters (Cal3DS2's first five): fx, fy, s, u0, v0.
  const bool colmap = ((k.model == "SIMPLE_PINHOLE" || k.model == "PINHOLE") && pinhole) ||
                      (k.model == "OPENCV" && opencv);
  if (colmap) basis(2, 2) = 0.0;
  if ((pinhole || opencv) && !principal_point) basis(3, 3) = basis(4, 4) = 0.0;
  if (k.model == "SIMPLE_PINHOLE" && pinhole) {
    basis(1, 0) = 1.0;  // fy follows fx
    basis(1, 1) = 0.0;
  } else if (k.model == "SIMPLE_RADIAL" && std::holds_alternative<Cal3Bundler>(k.calibration)) {
    basis(2, 2) = 0.0;  // f, k1, k2
  }
  return basis;
}

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
