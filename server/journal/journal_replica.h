// JournalReplica: a copy of the journal kept elsewhere (server/replication keeps one in a NATS
// JetStream stream on several machines). The Journal hands it every record it appends, framed as
// on disk (journal_format.h), after the local write succeeded; Commit() makes everything handed
// so far durable there. The daemon publishes the estimates of an update only after both the
// local sync and the replica's commit, so nothing an estimate includes exists on one machine only.
#pragma once

#include <cstdint>
#include <string_view>

#include "core/base/status.h"

namespace slamd::server {

class JournalReplica {
 public:
  virtual ~JournalReplica() = default;
  // Where a record leaves the journal: the sequence of the last accepted message appended so far
  // (this record's when it is a message) and the global offset just past the record.
  struct Position {
    std::int64_t last_message = 0;
    std::int64_t journal_end = 0;
  };
  // One framed record, in journal order. Never fails: what is not yet durable is kept.
  virtual void Stage(std::string_view frame, Position after) = 0;
  // Everything staged is durable in the replica; Unavailable when it could not be made so now
  // (kept for the next Commit), FailedPrecondition when this process may no longer write it.
  virtual core::Status Commit() = 0;
};

}  // namespace slamd::server
