#include "server/messages/wire_values.h"

#include <variant>

namespace slamd::server {

std::vector<double> ToValues(const core::Variable& variable) {
  std::vector<double> out;
  core::EncodeMessageValues(variable, &out);
  return out;
}

std::vector<double> ToRowMajor(const Eigen::Ref<const Eigen::MatrixXd>& matrix) {
  std::vector<double> out(static_cast<size_t>(matrix.size()));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      out.data(), matrix.rows(), matrix.cols()) = matrix;
  return out;
}

RelativePose ToPose(const std::vector<double>& v) {
  if (v.size() == 3) return core::Pose2(v[0], v[1], v[2]);
  return core::Pose3(core::Rot3::FromQuaternion(v[3], v[4], v[5], v[6]),
                     core::Point3(v[0], v[1], v[2]));
}

std::vector<double> PoseValues(const RelativePose& pose) {
  return std::visit([](const auto& p) { return ToValues(p); }, pose);
}

std::int8_t PoseDimension(const RelativePose& pose) {
  return std::holds_alternative<core::Pose2>(pose) ? 2 : 3;
}

}  // namespace slamd::server
