// Inbound <-> LCM bytes by type name, for what stores messages outside the queue: the journal
// (the bytes as received) and snapshots (held messages, re-encoded with ToLcm). Decoding runs
// the same validation and conversion as live intake, so a stored message is accepted exactly
// when a live one would be.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/status.h"
#include "server/ingest/validation.h"
#include "server/messages/inbound.h"

namespace slamd::server {

// `type` is the LCM type name without package ("odometry_t", ...). DataLoss for bytes that do
// not decode or an unknown type; InvalidArgument with the Verdict's message when the message
// decodes but fails validation.
core::Result<Inbound> DecodeInbound(std::string_view type, std::span<const std::uint8_t> bytes,
                                    const Limits& limits = {});

// The LCM encoding of `in` (queries included) and its type name.
std::vector<std::uint8_t> EncodeInbound(const Inbound& in, std::string* type);

}  // namespace slamd::server
