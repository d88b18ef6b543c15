#include "server/messages/inbound.h"

namespace slamd::server {

const char* MessageTypeName(const Inbound& in) {
  return VisitSpec(in, [](auto spec, const auto&) { return decltype(spec)::type::kType; });
}

const std::string& MessageRobot(const Inbound& in) {
  return VisitSpec(in, [](auto spec, const auto& m) -> const std::string& {
    return decltype(spec)::type::Robot(m);
  });
}

const std::vector<std::string>& InboundTypeNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> all;
    InboundSpecs::ForEach([&](auto spec) { all.push_back(decltype(spec)::type::kType); });
    return all;
  }();
  return names;
}

MessageRole MessageRoleOf(const Inbound& in) {
  return VisitSpec(in, [](auto spec, const auto&) { return decltype(spec)::type::kRole; });
}

std::int64_t MessageUtime(const Inbound& in) {
  return std::visit([](const auto& m) { return m.utime; }, in.measurement);
}

}  // namespace slamd::server
