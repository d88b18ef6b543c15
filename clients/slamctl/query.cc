// slamctl query KEY... [--cov] [--joint] [--json] [--map ROBOT]: asks slamd for estimates (and
// marginal covariances, a joint covariance, a robot's map) with one query_t and prints the
// query_reply_t (and map_t pages). Exit 1 when the server rejects the query or does not answer.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "clients/slamctl/client_common.h"
#include "clients/slamctl/dataset_messages.h"
#include "clients/slamctl/query_client.h"
#include "server/messages/inbound.h"

namespace slamd::clients {
namespace {

constexpr const char* kQueryCommand = "query";

struct QueryOptions {
  std::vector<std::string> keys;
  std::string robot;
  std::string map_robot;
  std::string client = "slamctl";
  bool cov = false;
  bool joint = false;
  bool json = false;
  double timeout_s = 5.0;
  ConnectionOptions connection;
};

void RunQueryCommand(const QueryOptions& opt) {
  if (opt.keys.empty() && opt.map_robot.empty()) {
    CommandFail(kQueryCommand, kExitUsage, "give at least one KEY (e.g. robot:x12) or --map ROBOT");
  }
  if (opt.keys.size() > 100) CommandFail(kQueryCommand, kExitUsage, "at most 100 keys per query");
  if (opt.joint && opt.keys.size() > 10) {
    CommandFail(kQueryCommand, kExitUsage, "--joint takes at most 10 keys");
  }
  if (!opt.map_robot.empty() && opt.map_robot != "*" && !IsValidRobotName(opt.map_robot)) {
    CommandFail(kQueryCommand, kExitUsage, "--map '" + opt.map_robot + "': a robot name or '*'");
  }
  server::QueryRequest request;
  request.client = opt.client;
  request.request_id = RandomRequestId();
  request.want_marginals = opt.cov;
  request.want_joint_marginal = opt.joint;
  request.map_robot = opt.map_robot;
  for (const std::string& text : opt.keys) {
    core::Result<server::WireKey> key = ParseKey(text, opt.robot);
    if (!key.ok()) CommandFail(kQueryCommand, kExitUsage, key.status().message());
    request.keys.push_back(*key);
  }
  slamd::query_t query;
  server::ToLcm(request, &query);
  query.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                    std::chrono::system_clock::now().time_since_epoch())
                    .count();
  server::ChannelNames channels;
  std::unique_ptr<LcmClient> client = ConnectOrFail(kQueryCommand, opt.connection, &channels);
  core::Result<QueryAnswer> answer = RunQuery(*client, channels, query, opt.timeout_s);
  if (!answer.ok()) {
    CommandFail(kQueryCommand, kExitFailure,
                answer.status().message() + " (is slamd running on " + client->url() + "?)");
  }
  std::fputs((opt.json ? AnswerJson(*answer) + "\n" : FormatAnswer(*answer)).c_str(), stdout);
  std::fflush(stdout);
  if (answer->reply.status == slamd::query_reply_t::STATUS_REJECTED) {
    CommandFail(kQueryCommand, kExitFailure, "query rejected: " + answer->reply.error);
  }
}

}  // namespace

void RegisterQuery(CLI::App& app) {
  auto opt = std::make_shared<QueryOptions>();
  CLI::App* cmd = app.add_subcommand(
      "query", "Ask slamd for estimates, marginal covariances and maps of some variables");
  cmd->add_option("key", opt->keys,
                  "Variables: ROBOT:xN (pose) or ROBOT:lN (landmark); xN / lN with --robot; mN "
                  "(landmark of the map all robots share)");
  cmd->add_option("--robot", opt->robot, "Robot of keys written without one");
  cmd->add_flag("--cov", opt->cov, "Also each key's marginal covariance");
  cmd->add_flag("--joint", opt->joint, "Also the joint covariance of all keys (at most 10)");
  cmd->add_option("--map", opt->map_robot,
                  "Also ROBOT's whole map ('*': every robot's and the shared map's)");
  cmd->add_option("--client", opt->client, "Client name echoed by the server")
      ->capture_default_str();
  cmd->add_option("--timeout", opt->timeout_s, "Longest wait for the reply [s]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "Print the answer as one JSON object");
  AddConnectionOptions(cmd, &opt->connection);
  cmd->callback([opt] { RunQueryCommand(*opt); });
}

}  // namespace slamd::clients
