#include "server/publish/wire_values.h"

#include "slamd/reject_t.hpp"

namespace slamd::server {

std::vector<double> ToValues(const core::Pose2& pose) { return {pose.x(), pose.y(), pose.theta()}; }

std::vector<double> ToValues(const core::Pose3& pose) {
  const Eigen::Quaterniond q = pose.rotation().ToQuaternion();  // qw >= 0
  const core::Point3& t = pose.translation();
  return {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()};
}

std::vector<double> ToValues(const core::Point2& point) { return {point.x(), point.y()}; }
std::vector<double> ToValues(const core::Point3& point) {
  return {point.x(), point.y(), point.z()};
}

std::vector<double> ToValues(const core::Variable& variable) {
  return std::visit([](const auto& v) { return ToValues(v); }, variable);
}

std::vector<double> ToRowMajor(const Eigen::Ref<const Eigen::MatrixXd>& matrix) {
  std::vector<double> out(static_cast<size_t>(matrix.size()));
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      out.data(), matrix.rows(), matrix.cols()) = matrix;
  return out;
}

void FillReject(const Verdict& verdict, std::string_view channel, std::string_view message_type,
                std::string_view robot, std::int64_t message_utime, std::int64_t now_utime,
                slamd::reject_t* out) {
  out->utime = now_utime;
  out->channel = std::string(channel);
  out->message_type = std::string(message_type);
  out->robot = std::string(robot);
  out->message_utime = message_utime;
  out->reason = static_cast<std::int32_t>(verdict.reason);
  out->detail = verdict.message;
}

}  // namespace slamd::server
