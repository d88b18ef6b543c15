#include "server/messages/inbound_codec.h"

#include "server/transport/typed_subscribe.h"

namespace slamd::server {

core::Result<Inbound> DecodeInbound(std::string_view type, std::span<const std::uint8_t> bytes,
                                    const Limits& limits) {
  std::optional<core::Result<Inbound>> decoded;
  InboundSpecs::ForEach([&](auto spec) {
    using Spec = typename decltype(spec)::type;
    if (decoded || type != Spec::kType) return;
    typename Spec::Lcm msg;
    if (const core::Status s = internal::DecodeAs(bytes, &msg); !s.ok()) {
      decoded = s;
      return;
    }
    auto checked = Convert(msg, limits);
    if (!checked.ok()) {
      decoded = core::InvalidArgument(checked.verdict().message);
    } else {
      decoded = Inbound{std::move(checked).value(), 0};
    }
  });
  if (!decoded) return core::DataLoss("unknown message type '" + std::string(type) + "'");
  return std::move(*decoded);
}

std::vector<std::uint8_t> EncodeInbound(const Inbound& in, std::string* type) {
  *type = MessageTypeName(in);
  return VisitSpec(in, [](auto spec, const auto& m) {
    typename decltype(spec)::type::Lcm msg;
    ToLcm(m, &msg);
    std::vector<std::uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
    SLAMD_CHECK(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) ==
                static_cast<int>(bytes.size()))
        << "LCM encode of " << decltype(spec)::type::kType << " failed";
    return bytes;
  });
}

}  // namespace slamd::server
