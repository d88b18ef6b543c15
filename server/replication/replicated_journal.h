// Starting the replicated journal: before the daemon appends to both, the stream must hold
// exactly the local journal's records up to some point, and gets the rest.
//   * The data directory has an id (file "replication-id", made once, 0600): the Slamd-Source of
//     the stream messages its journal becomes.
//   * The stream is empty: every record of the local journal is sent (the journal must still
//     start at offset 0: a stream started after segments were deleted would lack the history).
//   * The stream was last written from this data directory: the local records after its
//     Slamd-Journal-End are sent (appended before a crash, never acknowledged).
//   * The stream was last written from another data directory: FailedPrecondition (this one is
//     behind the stream: it can only follow it, as a standby).
// Then everything is committed and the journal stages each new record in the stream.
#pragma once

#include <memory>
#include <string>

#include "core/base/status.h"
#include "server/journal/journal.h"
#include "server/replication/stream_journal.h"

namespace slamd::server {

// The id of `data_dir` (16 hex digits), made and stored on first use. IoError when it cannot be
// read or written, DataLoss when the file holds something else.
core::Result<std::string> DataDirectoryId(const std::string& data_dir);

// See the file comment. `journal` is the data directory's open journal, nothing appended to it
// meanwhile; options.source is set here. The returned stream journal is the journal's replica:
// it must outlive it (or be detached: journal->set_replica(nullptr)).
core::Result<std::unique_ptr<StreamJournal>> StartReplication(const std::string& data_dir,
                                                              StreamJournalOptions options,
                                                              Journal* journal);

// A standby taking over the stream it followed: its journal is a copy of the stream's records
// up to stream message `consumed`. FailedPrecondition when the stream holds more (read on and
// call again). The returned stream journal is the journal's replica, as above.
core::Result<std::unique_ptr<StreamJournal>> TakeOverReplication(const std::string& data_dir,
                                                                 StreamJournalOptions options,
                                                                 Journal* journal,
                                                                 std::int64_t consumed);

}  // namespace slamd::server
