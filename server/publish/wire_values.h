// Core types -> the value and covariance arrays of the LCM types (the layouts documented in
// msgs/lcm), and reject_t construction. Used by the publisher and by ToLcm (conversion.h).
//
//   variables -> VariableTraits::EncodeMessage (Pose2 (x, y, theta), theta in (-pi, pi];
//                Pose3 (x, y, z, qw, qx, qy, qz), qw >= 0; Point2 (x, y), Point3 (x, y, z))
//   matrix    -> row-major
// Tangent orders are slamd's (translation first), so covariances are copied as they are.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/geometry/pose2.h"
#include "core/geometry/pose3.h"
#include "core/variables/variable.h"
#include "server/ingest/validation.h"

namespace slamd {
class reject_t;
}  // namespace slamd

namespace slamd::server {

std::vector<double> ToValues(const core::Variable& variable);
std::vector<double> ToRowMajor(const Eigen::Ref<const Eigen::MatrixXd>& matrix);

// Fills *out for a rejected message: `verdict` (not ok) gives reason and detail; `channel`,
// `message_type` (e.g. "odometry_t"), `robot` and `message_utime` name the message; `now_utime`
// is the rejection time [µs].
void FillReject(const Verdict& verdict, std::string_view channel, std::string_view message_type,
                std::string_view robot, std::int64_t message_utime, std::int64_t now_utime,
                slamd::reject_t* out);

}  // namespace slamd::server
