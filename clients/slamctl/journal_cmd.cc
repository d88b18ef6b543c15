// slamctl journal inspect DATA_DIR|FILE [--json] [--salvage]
// slamctl journal export DATA_DIR|FILE -o DIR [--salvage] [--no-g2o] [--no-lcm-log]
// slamctl journal bench DATASET (bench_journal.h)
// Read a slamd journal (a data directory's segments, or one segment file) offline; see
// journal_export.h. The journal is
// only read, never modified (a live slamd may keep appending: records after the file size seen
// at open are not read).
// Exit codes: 0 ok (inspect: also for a torn tail, which slamd repairs itself); 1 the file cannot
// be read, or (inspect) corruption in the middle, or (export) a write failed; 2 bad arguments.
#include <cstdio>
#include <memory>
#include <string>

#include "clients/slamctl/bench_journal.h"
#include "clients/slamctl/client_common.h"
#include "clients/slamctl/commands.h"
#include "clients/slamctl/journal_export.h"

namespace slamd::clients {
namespace {

struct JournalOptions {
  std::string file;
  std::string out_dir;
  bool json = false;
  bool salvage = false;
  bool no_g2o = false;
  bool no_lcm_log = false;
};

void RunInspect(const JournalOptions& opt) {
  core::Result<JournalInspection> r = InspectJournal(opt.file, opt.salvage);
  if (!r.ok()) CommandFail("journal inspect", kExitFailure, r.status().ToString());
  const std::string text =
      opt.json ? InspectionJson(r.value()) + "\n" : FormatInspection(r.value());
  std::fputs(text.c_str(), stdout);
  std::fflush(stdout);
  if (r.value().end == "corruption") throw CommandExit{kExitFailure};
}

void RunExport(const JournalOptions& opt) {
  if (opt.no_g2o && opt.no_lcm_log) {
    CommandFail("journal export", kExitUsage, "--no-g2o and --no-lcm-log leave nothing to do");
  }
  core::Result<JournalExportResult> r =
      ExportJournal(opt.file, opt.out_dir,
                    {.salvage = opt.salvage, .g2o = !opt.no_g2o, .lcm_log = !opt.no_lcm_log});
  if (!r.ok()) CommandFail("journal export", kExitFailure, r.status().ToString());
  const JournalExportResult& e = r.value();
  std::printf("%lld messages exported", static_cast<long long>(e.messages));
  if (!e.lcm_log.empty()) std::printf("; LCM log %s", e.lcm_log.c_str());
  std::printf("\n");
  for (const auto& [robot, path] : e.g2o)
    std::printf("g2o: %s (robot %s)\n", path.c_str(), robot.c_str());
  if (!opt.no_g2o) {
    std::printf("%lld edges; %lld repeated measurements dropped; %lld retracted\n",
                static_cast<long long>(e.exported_factors), static_cast<long long>(e.duplicates),
                static_cast<long long>(e.removed));
  }
  for (const std::string& note : e.notes) std::printf("note: %s\n", note.c_str());
  std::fflush(stdout);
}

}  // namespace

void RegisterJournal(CLI::App& app) {
  auto opt = std::make_shared<JournalOptions>();
  CLI::App* cmd = app.add_subcommand("journal", "Inspect or export a slamd journal offline");
  cmd->require_subcommand(1);

  CLI::App* inspect = cmd->add_subcommand(
      "inspect", "Print the records of a journal and how it ends (torn tail, corruption)");
  inspect->add_option("PATH", opt->file, "a slamd data directory, or one journal segment file")
      ->required()
      ->check(CLI::ExistingPath);
  inspect->add_flag("--json", opt->json, "Print one JSON object");
  inspect->add_flag("--salvage", opt->salvage, "Skip corrupt regions in the middle");
  inspect->callback([opt] { RunInspect(*opt); });

  CLI::App* exp = cmd->add_subcommand(
      "export", "Export the journaled measurements as g2o (one file per robot) and an LCM log");
  exp->add_option("PATH", opt->file, "a slamd data directory, or one journal segment file")
      ->required()
      ->check(CLI::ExistingPath);
  exp->add_option("-o,--output", opt->out_dir, "output directory (created if needed)")->required();
  exp->add_flag("--salvage", opt->salvage, "Skip corrupt regions in the middle");
  exp->add_flag("--no-g2o", opt->no_g2o, "Write no g2o files");
  exp->add_flag("--no-lcm-log", opt->no_lcm_log, "Write no LCM log");
  exp->callback([opt] { RunExport(*opt); });

  RegisterJournalBench(cmd);
}

}  // namespace slamd::clients
