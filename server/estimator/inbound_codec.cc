#include "server/estimator/inbound_codec.h"

#include "server/ingest/conversion.h"
#include "server/transport/typed_subscribe.h"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/query_t.hpp"
#include "slamd/remove_factor_t.hpp"

namespace slamd::server {
namespace {

template <typename Msg>
core::Result<Inbound> Decode(std::span<const std::uint8_t> bytes, const Limits& limits) {
  Msg msg;
  SLAMD_RETURN_IF_ERROR(internal::DecodeAs(bytes, &msg));
  auto checked = Convert(msg, limits);
  if (!checked.ok()) return core::InvalidArgument(checked.verdict().message);
  return Inbound{std::move(checked).value(), 0};
}

template <typename Msg, typename M>
std::vector<std::uint8_t> Encode(const M& m) {
  Msg msg;
  ToLcm(m, &msg);
  std::vector<std::uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  SLAMD_CHECK(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) ==
              static_cast<int>(bytes.size()))
      << "LCM encode of " << Msg::getTypeName() << " failed";
  return bytes;
}

}  // namespace

core::Result<Inbound> DecodeInbound(std::string_view type, std::span<const std::uint8_t> bytes,
                                    const Limits& limits) {
  if (type == "odometry_t") return Decode<slamd::odometry_t>(bytes, limits);
  if (type == "landmark_observation_t") {
    return Decode<slamd::landmark_observation_t>(bytes, limits);
  }
  if (type == "loop_closure_t") return Decode<slamd::loop_closure_t>(bytes, limits);
  if (type == "prior_t") return Decode<slamd::prior_t>(bytes, limits);
  if (type == "remove_factor_t") return Decode<slamd::remove_factor_t>(bytes, limits);
  if (type == "query_t") return Decode<slamd::query_t>(bytes, limits);
  return core::DataLoss("unknown message type '" + std::string(type) + "'");
}

std::vector<std::uint8_t> EncodeInbound(const Inbound& in, std::string* type) {
  *type = MessageTypeName(in);
  return std::visit(
      [](const auto& m) {
        using M = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<M, OdometryMeasurement>) {
          return Encode<slamd::odometry_t>(m);
        } else if constexpr (std::is_same_v<M, LandmarkMeasurement>) {
          return Encode<slamd::landmark_observation_t>(m);
        } else if constexpr (std::is_same_v<M, LoopClosureMeasurement>) {
          return Encode<slamd::loop_closure_t>(m);
        } else if constexpr (std::is_same_v<M, PriorMeasurement>) {
          return Encode<slamd::prior_t>(m);
        } else if constexpr (std::is_same_v<M, RemoveFactorRequest>) {
          return Encode<slamd::remove_factor_t>(m);
        } else {
          return Encode<slamd::query_t>(m);
        }
      },
      in.measurement);
}

}  // namespace slamd::server
