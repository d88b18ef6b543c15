// slamd: the real-time incremental SLAM server. A thin shell: flags and config -> ServerParams,
// logging, an LcmBus, a Daemon; SIGINT/SIGTERM stop it cleanly (exit 0).
//
//   slamd [--config FILE] [--lcm-url URL] [--data-dir DIR] [--channel-prefix P] [--log-level L]
//   slamd --print-default-config
// Exit codes: 0 clean stop, 2 bad flags or config, 1 runtime failure (e.g. LCM cannot start),
// 3 deposed: a replicated pair's leader lost its lease or found another writer on the stream,
// or a standby could not follow it (restarted as is, it follows the stream again).
#include <spdlog/async.h>
#include <spdlog/sinks/rotating_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>
#include <memory>
#include <string>

#include "core/base/memory_usage.h"
#include "server/config/config_loader.h"
#include "server/daemon/daemon.h"
#include "server/transport/lcm_bus.h"

namespace {

using slamd::server::ServerParams;

// An async, non-blocking logger named "slamd" (the estimator thread never waits on I/O): the
// console, plus a rotating file (10 MB x 3) when configured.
std::shared_ptr<spdlog::logger> MakeLogger(const ServerParams& params) {
  spdlog::init_thread_pool(8192, 1);
  std::vector<spdlog::sink_ptr> sinks = {std::make_shared<spdlog::sinks::stderr_color_sink_mt>()};
  if (!params.log_file.empty()) {
    sinks.push_back(std::make_shared<spdlog::sinks::rotating_file_sink_mt>(params.log_file,
                                                                           10 * 1024 * 1024, 3));
  }
  auto logger = std::make_shared<spdlog::async_logger>(
      "slamd", sinks.begin(), sinks.end(), spdlog::thread_pool(),
      spdlog::async_overflow_policy::overrun_oldest);
  logger->set_level(
      static_cast<spdlog::level::level_enum>(slamd::server::LogLevelNumber(params.log_level)));
  logger->flush_on(spdlog::level::warn);
  spdlog::register_logger(logger);
  return logger;
}

}  // namespace

int main(int argc, char** argv) {
  slamd::core::KeepFreedMemoryForReuse();
  CLI::App app{"slamd: real-time incremental SLAM server (LCM in, estimates out)"};
  std::string config_path, lcm_url, data_dir, channel_prefix, log_level;
  bool print_default = false;
  app.add_option("--config", config_path,
                 "config file (protobuf text format, msgs/proto/config.proto)");
  app.add_option("--lcm-url", lcm_url, "LCM URL (overrides lcm_url)");
  app.add_option("--data-dir", data_dir, "journal and snapshot directory (overrides data_dir)");
  bool salvage = false;
  app.add_flag("--salvage", salvage,
               "at recovery, skip corrupt journal records instead of refusing to start");
  app.add_option("--channel-prefix", channel_prefix,
                 "channel name prefix (overrides channel_prefix)");
  app.add_option("--log-level", log_level,
                 "trace|debug|info|warn|error|critical|off (overrides log_level)");
  app.add_flag("--print-default-config", print_default,
               "print a commented default config and exit");
  CLI11_PARSE(app, argc, argv);

  if (print_default) {
    std::fputs(slamd::server::DefaultConfigText().c_str(), stdout);
    return 0;
  }
  ServerParams params;
  if (!config_path.empty()) {
    slamd::core::Result<ServerParams> loaded = slamd::server::LoadConfigFile(config_path);
    if (!loaded.ok()) {
      std::fprintf(stderr, "slamd: %s\n", loaded.status().message().c_str());
      return 2;
    }
    params = std::move(loaded).value();
  }
  if (app.count("--lcm-url")) params.lcm_url = lcm_url;
  if (app.count("--data-dir")) params.data_dir = data_dir;
  if (app.count("--channel-prefix")) params.channel_prefix = channel_prefix;
  if (app.count("--log-level")) params.log_level = log_level;
  params.salvage = salvage;
  if (const slamd::core::Status valid = params.Validate(); !valid.ok()) {
    std::fprintf(stderr, "slamd: %s\n", valid.message().c_str());
    return 2;
  }

  // Signals are taken by sigwait on this thread only: block them before any thread starts.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // A journal write beyond RLIMIT_FSIZE must fail with EFBIG (rejected, counted), not kill us.
  std::signal(SIGXFSZ, SIG_IGN);

  const std::shared_ptr<spdlog::logger> log = MakeLogger(params);
  auto bus = slamd::server::LcmBus::Create({.url = params.lcm_url});
  if (!bus.ok()) {
    log->critical("{}", bus.status().ToString());
    spdlog::shutdown();
    return 1;
  }
  auto daemon = slamd::server::Daemon::Create(params, bus.value().get());
  if (!daemon.ok()) {
    log->critical("{}", daemon.status().ToString());
    spdlog::shutdown();
    return 1;
  }
  daemon.value()->Start();
  // Until a signal, or until this slamd of a replicated pair is deposed (it lost the lease, or
  // another slamd wrote the stream): then it stops with exit code 3.
  const timespec tick{.tv_sec = 0, .tv_nsec = 100'000'000};
  int signal = -1;
  while (signal < 0 && !daemon.value()->deposed()) signal = sigtimedwait(&signals, nullptr, &tick);
  if (signal > 0) {
    log->info("signal {}: stopping intake, finishing the update", signal);
  } else {
    log->critical(
        "no longer the leader of the replicated pair, or a standby that cannot follow it: "
        "stopping (exit 3)");
  }
  daemon.value()->Stop();
  daemon.value().reset();
  spdlog::shutdown();
  return signal > 0 ? 0 : 3;
}
