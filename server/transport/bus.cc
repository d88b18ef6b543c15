#include "server/transport/bus.h"

#include <utility>

namespace slamd::server {

Subscription::Subscription(Subscription&& other) noexcept
    : unsubscribe_(std::exchange(other.unsubscribe_, nullptr)) {}

Subscription& Subscription::operator=(Subscription&& other) noexcept {
  if (this != &other) {
    Unsubscribe();
    unsubscribe_ = std::exchange(other.unsubscribe_, nullptr);
  }
  return *this;
}

void Subscription::Unsubscribe() {
  // Cleared before the call, so a re-entrant Unsubscribe (or the destructor) cannot run it twice.
  auto unsubscribe = std::exchange(unsubscribe_, nullptr);
  if (unsubscribe) unsubscribe();
}

core::Status CheckChannelName(std::string_view channel) {
  if (channel.empty()) return core::InvalidArgument("channel name is empty");
  if (channel.size() > static_cast<size_t>(kMaxChannelNameLength)) {
    return core::InvalidArgument("channel name '" + std::string(channel) + "' has " +
                                 std::to_string(channel.size()) + " chars; the limit is " +
                                 std::to_string(kMaxChannelNameLength));
  }
  return core::Status::Ok();
}

}  // namespace slamd::server
