#include "server/replication/relay_bus.h"

#include "core/base/check.h"

namespace slamd::server {

std::vector<std::uint8_t> Frame(std::string_view tag, std::span<const std::uint8_t> body) {
  SLAMD_CHECK(!tag.empty() && tag.size() <= 255) << "frame tag of " << tag.size() << " bytes";
  std::vector<std::uint8_t> out;
  out.reserve(1 + tag.size() + body.size());
  out.push_back(static_cast<std::uint8_t>(tag.size()));
  out.insert(out.end(), tag.begin(), tag.end());
  out.insert(out.end(), body.begin(), body.end());
  return out;
}

std::optional<Framed> Unframe(std::span<const std::uint8_t> payload) {
  if (payload.empty() || payload[0] == 0 || payload.size() < 1u + payload[0]) return std::nullopt;
  const std::size_t n = payload[0];
  return Framed{.tag = std::string_view(reinterpret_cast<const char*>(payload.data() + 1), n),
                .body = payload.subspan(1 + n)};
}

core::Status RelayBus::Publish(std::string_view channel, std::span<const std::uint8_t> bytes) {
  if (!channel.starts_with(prefix_) || channel.size() == prefix_.size() ||
      channel.size() - prefix_.size() > 255) {
    return core::InvalidArgument("relay of channel '" + std::string(channel) +
                                 "': not a channel of prefix '" + prefix_ + "'");
  }
  return nats_->Publish(subject_, Frame(channel.substr(prefix_.size()), bytes));
}

core::Result<Subscription> RelayBus::Subscribe(std::string_view, MessageCallback) {
  return core::FailedPrecondition("RelayBus only publishes");
}

core::Result<int> RelayBus::HandleFor(std::chrono::microseconds) {
  return core::FailedPrecondition("RelayBus only publishes");
}

}  // namespace slamd::server
