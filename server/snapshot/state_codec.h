// EstimatorState <-> bytes (msgs/proto/snapshot.proto), the content of a snapshot file
// (server/journal/snapshot_file.h frames and checksums it). Geometry round-trips exactly
// (rotation matrices, (cos, sin)); noise models through their square-root information.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/base/status.h"
#include "server/snapshot/estimator_state.h"
#include "slamd_proto/snapshot.pb.h"

namespace slamd::server {

// The journal position a state includes: every accepted message with a sequence up to
// last_message_sequence, and every update-boundary / refinement record before journal_offset.
struct JournalPosition {
  std::int64_t last_message_sequence = 0;
  std::int64_t journal_offset = 0;
};

std::string EncodeState(const EstimatorState& state, const JournalPosition& position);

// DataLoss naming what is wrong (unparseable bytes, a factor of unknown type or with the wrong
// number of keys or values, a noise model that is not square-root information).
core::Result<EstimatorState> DecodeState(std::string_view bytes, JournalPosition* position);

// Values as a snapshot stores them (exactly), and back (DataLoss naming `what` and the fault,
// as DecodeState's): also for records that carry values outside a snapshot (the journal's node
// removals).
void EncodeValues(const core::Values& values,
                  google::protobuf::RepeatedPtrField<snapshot::KeyedVariable>* out);
core::Status DecodeValues(const google::protobuf::RepeatedPtrField<snapshot::KeyedVariable>& in,
                          const char* what, core::Values* out);
// A pose alias (reduced pose graph, lifelong window) as a snapshot stores it, and back
// (DataLoss naming the pose: an unreadable offset, a covariance not n x n finite numbers):
// also for the journal's node removals.
void EncodeAlias(core::Key pose, const PoseAlias& alias, snapshot::PoseAlias* out);
core::Result<PoseAlias> DecodeAlias(const snapshot::PoseAlias& in);

}  // namespace slamd::server
