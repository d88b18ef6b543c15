// Core types <-> the value and covariance arrays of the LCM types (the layouts documented in
// msgs/lcm). Used by the message specs (Convert / ToLcm) and the publisher.
//
//   variables -> VariableTraits::EncodeMessage (Pose2 (x, y, theta), theta in (-pi, pi];
//                Pose3 (x, y, z, qw, qx, qy, qz), qw >= 0; Point2 (x, y), Point3 (x, y, z))
//   matrix    -> row-major
// Tangent orders are slamd's (translation first), so covariances are copied as they are.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/factors/noise_model.h"
#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"
#include "core/variables/variable.h"
#include "server/ingest/measurements.h"

namespace slamd::server {

std::vector<double> ToValues(const core::Variable& variable);
std::vector<double> ToRowMajor(const Eigen::Ref<const Eigen::MatrixXd>& matrix);

// A validated message's pose values: 3 (x, y, theta) -> Pose2, 7 (x, y, z, qw, qx, qy, qz) ->
// Pose3 (quaternion normalised), and back (qw >= 0); its dimension field (2 or 3).
RelativePose ToPose(const std::vector<double>& values);
std::vector<double> PoseValues(const RelativePose& pose);
std::int8_t PoseDimension(const RelativePose& pose);
// Fills a message's values / covariance pairs (counts from the vectors, so they always agree).
template <typename Msg>
void SetMeasurement(std::vector<double> values, const core::NoiseModel& noise, Msg* out) {
  out->values = std::move(values);
  out->num_values = static_cast<std::int32_t>(out->values.size());
  out->covariance = ToRowMajor(noise.Covariance());
  out->num_covariance = static_cast<std::int32_t>(out->covariance.size());
}

}  // namespace slamd::server
