// The slamctl subcommands. Each Register function adds one subcommand (its options and its
// callback) to the top-level app; main.cc only wires them together.
#pragma once

#include <CLI/CLI.hpp>

namespace slamd::clients {

// `slamctl bench DATASET`: offline timing and accuracy of the core solvers on a dataset.
void RegisterBench(CLI::App& app);
void RegisterReplay(CLI::App& app);  // `slamctl replay SOURCE...`: stream datasets / an LCM log into slamd
void RegisterStatus(CLI::App& app);  // `slamctl status`: print one status_t
void RegisterWatch(CLI::App& app);  // `slamctl watch`: live view of estimates and status
void RegisterQuery(CLI::App& app);  // `slamctl query KEY...`: estimates, covariances, maps
// `slamctl sim WORLD -o DIR`: a synthetic world (dataset + ground truth), deterministic per seed.
void RegisterSim(CLI::App& app);
// `slamctl plot DATASET... -o OUT.png|svg|pdf`: top-down picture of datasets (plot.cc).
void RegisterPlot(CLI::App& app);
void RegisterJournal(CLI::App& app);  // `slamctl journal inspect|export|bench`: journal offline

// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // the work itself failed (solver error, unreadable file)
inline constexpr int kExitUsage = 2;    // bad arguments

// Thrown by a subcommand callback to end the program with a code after printing its message.
struct CommandExit {
  int code;
};

}  // namespace slamd::clients
