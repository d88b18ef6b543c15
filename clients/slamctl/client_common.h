// What the slamctl subcommands share: the connection options to a live slamd (--lcm-url,
// --channel-prefix), connecting, failing with an exit code, printing status_t, and parsing a
// WIDTHxHEIGHT size.
#pragma once

#include <memory>
#include <string>

#include "clients/slamctl/commands.h"
#include "clients/slamctl/json_writer.h"
#include "clients/slamctl/lcm_client.h"
#include "server/transport/channels.h"
#include "slamd/status_t.hpp"

namespace slamd::clients {

struct ConnectionOptions {
  std::string lcm_url;                    // "" = DefaultLcmUrl()
  std::string channel_prefix = "SLAMD_";  // as slamd's channel_prefix
};

// Adds --lcm-url and --channel-prefix to `cmd`.
void AddConnectionOptions(CLI::App* cmd, ConnectionOptions* options);

// Prints "slamctl <command>: <message>" to stderr and ends the command with `code`.
[[noreturn]] void CommandFail(const std::string& command, int code, const std::string& message);

// InvalidArgument unless `prefix` is 1..40 chars of [A-Za-z0-9_] (slamd's rule).
core::Status CheckChannelPrefix(const std::string& prefix);

// Validates the options (exit 2) and connects (exit 1 when LCM cannot start).
std::unique_ptr<LcmClient> ConnectOrFail(const std::string& command,
                                         const ConnectionOptions& options,
                                         server::ChannelNames* channels);

// A few readable lines describing `status` (counters, queue, latency, chi2, settled).
std::string FormatStatus(const slamd::status_t& status);
// The same as a JSON object (every field; rejects_by_reason as {reason_name: count} for the
// non-zero ones).
JsonWriter StatusJson(const slamd::status_t& status);

// "1200x900" -> width, height; false when malformed (the numbers are not range-checked).
bool ParseSize(const std::string& text, int* width, int* height);

// True when stderr / stdout is a terminal.
bool StderrIsTty();
bool StdoutIsTty();

}  // namespace slamd::clients
