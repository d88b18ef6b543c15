// slamctl status: waits for one status_t from slamd and prints it (readably, or --json).
// Exit 1 when none arrives within --timeout.
#include <memory>
#include <optional>

#include "clients/slamctl/client_common.h"

namespace slamd::clients {
namespace {

constexpr const char* kStatusCommand = "status";

struct StatusOptions {
  double timeout_s = 3.0;
  bool json = false;
  ConnectionOptions connection;
};

void RunStatus(const StatusOptions& opt) {
  server::ChannelNames channels;
  std::unique_ptr<LcmClient> client = ConnectOrFail(kStatusCommand, opt.connection, &channels);
  std::optional<slamd::status_t> status;
  const core::Status sub = client->Subscribe<slamd::status_t>(
      channels.Status(), [&](const slamd::status_t& s) { status = s; });
  if (!sub.ok()) CommandFail(kStatusCommand, kExitFailure, sub.ToString());
  core::Result<bool> got = client->HandleUntil([&] { return status.has_value(); }, opt.timeout_s);
  if (!got.ok()) CommandFail(kStatusCommand, kExitFailure, got.status().ToString());
  if (!*got) {
    CommandFail(kStatusCommand, kExitFailure,
                "no status_t on " + channels.Status() + " within " + std::to_string(opt.timeout_s) +
                    " s (is slamd running on " + client->url() +
                    " with this --channel-prefix and publish.status_rate_hz > 0?)");
  }
  const std::string text = opt.json ? StatusJson(*status).str() + "\n" : FormatStatus(*status);
  std::fputs(text.c_str(), stdout);
  std::fflush(stdout);
}

}  // namespace

void RegisterStatus(CLI::App& app) {
  auto opt = std::make_shared<StatusOptions>();
  CLI::App* cmd = app.add_subcommand("status", "Wait for one status_t from slamd and print it");
  cmd->add_option("--timeout", opt->timeout_s, "Longest wait [s]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "Print the status as one JSON object");
  AddConnectionOptions(cmd, &opt->connection);
  cmd->callback([opt] { RunStatus(*opt); });
}

}  // namespace slamd::clients
