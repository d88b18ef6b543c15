// What `slamctl journal inspect|export` does with a slamd journal (server/journal: a data
// directory's segment files, or one of them), as a library so tests can call it. Offsets are
// global (journal_segments.h): a journal whose older segments were deleted starts after 0.
//
// InspectJournal lists every record (frame offset, kind, sequence, LCM type, robot, frame size)
// and how the file ends: clean, a torn tail (a crash mid-write; recovery truncates it) or
// corruption in the middle (recovery refuses to start without --salvage). It never modifies the
// file. With salvage, corrupt regions are skipped and listed, as `slamd --salvage` would.
//
// ExportJournal turns the journal's accepted measurements into files a run can be reproduced
// from offline:
//   <out>/journal.lcmlog   every journaled message (queries are never journaled), in journal
//                          order, as an LCM event log (lcm::LogFile): the channel as journaled
//                          (prefix included), the exact LCM bytes, event timestamp =
//                          received_wall_us. `slamctl replay <out>/journal.lcmlog` replays it.
//   <out>/<robot>.g2o      one g2o dataset per robot (core::WriteG2o; ReadDataset reads it back):
//                          odometry and same-robot loop closures -> EDGE_SE2 / EDGE_SE3:QUAT;
//                          2D relative-point landmark observations -> EDGE_SE2_XY; 2D
//                          bearing-range observations -> EDGE_SE2_XY at (r cos b, r sin b) with
//                          the first-order covariance J Σ Jᵀ (g2o has no bearing-range edge).
//                          A pose prior becomes the pose's vertex value plus a FIX line.
//                          Vertex values (the initial guess) are composed along the measurements
//                          in journal order, starting at the prior or the identity.
// What a g2o file cannot hold is counted in the result's notes and left to the LCM log:
// loop closures between two robots, 3D landmark observations, position priors. Measurements are
// exported as the estimator would have kept them: a repeat of an earlier measurement (same type
// between the same variables, the estimator's kDuplicate) is dropped, and a remove_factor_t
// retracts the measurement it names (which may then be sent again).
// Errors: those of reading the journal (corruption in the middle without salvage is DataLoss
// naming the offset; a torn tail is fine: the records before it are exported), IoError when an
// output file cannot be written. The output directory is created if needed.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/base/status.h"

namespace slamd::clients {

struct JournalRecordInfo {
  std::int64_t offset = 0;  // frame offset in the journal [bytes]
  std::int64_t size = 0;    // frame size: header + payload [bytes]
  std::string kind = "";    // "message", "boundary", "refinement" or "rebuild" (swap)
  // message: its sequence; boundary and rebuild: the update sequence; refinement: 0.
  std::int64_t sequence = 0;
  std::string type = "";     // message: LCM type name ("odometry_t"); "" otherwise
  std::string channel = "";  // message: channel as journaled
  std::string robot = "";    // message: robot (robot_a of a loop closure); "" if undecodable
  // boundary: "last=<seq> count=<n>"; refinement: "rounds=<n>"; message: "" or why it does not
  // decode.
  std::string detail = "";
};

struct JournalInspection {
  std::vector<JournalRecordInfo> records;
  std::int64_t messages = 0, boundaries = 0, refinements = 0, rebuild_swaps = 0;
  std::map<std::string, std::int64_t> messages_by_type;
  std::int64_t file_size = 0;     // where the journal ends [bytes]
  std::int64_t first_offset = 0;  // where its oldest kept segment starts [bytes]
  std::int64_t disk_bytes = 0;    // its segments' bytes [bytes]
  int segments = 0;
  std::int64_t valid_end_offset = 0;   // end of the last valid record [bytes]
  std::string end;                     // "clean", "torn tail" or "corruption"
  std::int64_t torn_tail_offset = -1;  // when end == "torn tail"
  std::string end_reason;              // why the torn tail / corrupt record is not valid
  std::string corruption;              // when end == "corruption": the reader's error
  std::int64_t skipped_bytes = 0;      // under salvage
  std::vector<std::string> skipped;    // under salvage: "offset +length: reason"
};

// Errors only when the file cannot be opened or has a bad header (NotFound / IoError /
// DataLoss); a torn tail or corruption is reported in the result.
core::Result<JournalInspection> InspectJournal(const std::string& path, bool salvage);

// Human-readable table and summary; one JSON object.
std::string FormatInspection(const JournalInspection& inspection);
std::string InspectionJson(const JournalInspection& inspection);

struct JournalExportOptions {
  bool salvage = false;  // skip corrupt regions in the middle (else DataLoss)
  bool g2o = true;       // write the per-robot g2o files
  bool lcm_log = true;   // write journal.lcmlog
};

struct JournalExportResult {
  std::string lcm_log;                     // path written ("" when not asked for)
  std::map<std::string, std::string> g2o;  // robot -> path written
  std::int64_t messages = 0;               // message records read
  std::int64_t exported_factors = 0;       // edges written over all g2o files
  std::int64_t duplicates = 0;             // repeats dropped
  std::int64_t removed = 0;                // retracted by remove_factor_t
  std::vector<std::string> notes;          // what was not exported to g2o and why; torn tail
};

core::Result<JournalExportResult> ExportJournal(const std::string& journal_path,
                                                const std::string& out_dir,
                                                const JournalExportOptions& options = {});

}  // namespace slamd::clients
