// EstimatorState <-> bytes (msgs/proto/snapshot.proto), the content of a snapshot file
// (server/journal/snapshot_file.h frames and checksums it). Geometry round-trips exactly
// (rotation matrices, (cos, sin)); noise models through their square-root information.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/base/status.h"
#include "server/estimator/estimator_state.h"

namespace slamd::server {

// `last_message_sequence`: the journal position the state includes (every accepted message
// with a sequence up to it).
std::string EncodeState(const EstimatorState& state, std::int64_t last_message_sequence);

// DataLoss naming what is wrong (unparseable bytes, a factor of unknown type or with the wrong
// number of keys or values, a noise model that is not square-root information).
core::Result<EstimatorState> DecodeState(std::string_view bytes,
                                         std::int64_t* last_message_sequence);

}  // namespace slamd::server
