#include "server/publish/wire_values.h"

#include "slamd/reject_t.hpp"

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
