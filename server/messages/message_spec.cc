#include "server/messages/message_spec.h"

namespace slamd::server {

std::string PoseName(const std::string& robot, std::uint64_t index) {
  return "robot '" + robot + "' pose " + std::to_string(index);
}

bool SamePoseType(const core::Variable& pose, const RelativePose& measured) {
  return std::holds_alternative<core::Pose2>(measured) ? std::holds_alternative<core::Pose2>(pose)
                                                       : std::holds_alternative<core::Pose3>(pose);
}

}  // namespace slamd::server
