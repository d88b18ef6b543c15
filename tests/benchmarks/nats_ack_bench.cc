// nats_ack_bench: how long a JetStream append waits for its acknowledgement on this machine, the
// floor under what the replicated journal adds to slamd's ingest-to-publish latency (each update
// waits for one acknowledged append before its estimates go out). It appends `--messages`
// records of `--bytes` at `--rate` per second, one at a time as slamd's commit does
// (server/replication PublishToStream), and prints the acknowledgement's percentiles.
// `--busy-threads K` keeps K threads of this process spinning meanwhile, standing in for slamd's
// estimator sharing the machine's cores with the NATS servers. A tool run by hand
// (scripts/bench-nats-ack starts the cluster; figures in BENCHMARKS.md).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "core/base/percentile.h"
#include "server/replication/nats_client.h"

namespace {

using Clock = std::chrono::steady_clock;
using slamd::core::Percentile;

struct Options {
  std::string servers;
  std::string stream = "ACKBENCH";
  int messages = 5000;
  double rate = 1000.0;
  int bytes = 300;
  int replicas = 3;
  int busy_threads = 0;
};

int Run(const Options& opt) {
  using slamd::server::NatsClient;
  auto client = NatsClient::Connect({.servers = slamd::server::SplitServers(opt.servers)});
  if (!client.ok()) {
    std::fprintf(stderr, "nats_ack_bench: %s\n", client.status().ToString().c_str());
    return 1;
  }
  jsCtx* js = client.value()->jetstream();
  const std::string subject = "ackbench." + opt.stream;
  auto opened = slamd::server::OpenStream(
      js, {.name = opt.stream, .subject = subject, .replicas = opt.replicas});
  if (!opened.ok()) {
    std::fprintf(stderr, "nats_ack_bench: %s\n", opened.status().ToString().c_str());
    return 1;
  }
  std::atomic<bool> stop{false};
  std::vector<std::thread> busy;
  for (int t = 0; t < opt.busy_threads; ++t) {
    busy.emplace_back([&stop] {
      volatile double x = 1.0;
      while (!stop.load(std::memory_order_relaxed)) x = x * 1.0000001 + 1e-9;
    });
  }
  const std::string payload(static_cast<std::size_t>(opt.bytes), 'x');
  std::vector<double> ack_ms;
  ack_ms.reserve(static_cast<std::size_t>(opt.messages));
  const auto period = std::chrono::duration<double>(1.0 / opt.rate);
  const Clock::time_point start = Clock::now();
  int status = 0;
  for (int i = 0; i < opt.messages; ++i) {
    std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(i * period));
    const Clock::time_point sent = Clock::now();
    int js_error = 0;
    auto stored = slamd::server::PublishToStream(js, {.subject = subject, .payload = payload},
                                                 10000, "append " + std::to_string(i), &js_error);
    if (!stored.ok()) {
      std::fprintf(stderr, "nats_ack_bench: %s\n", stored.status().ToString().c_str());
      status = 1;
      break;
    }
    ack_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - sent).count());
  }
  stop = true;
  for (std::thread& t : busy) t.join();
  if (status != 0 || ack_ms.empty()) return 1;
  std::printf(
      "{\"replicas\": %d, \"busy_threads\": %d, \"messages\": %zu, \"rate\": %.0f, \"bytes\": %d, "
      "\"ack_ms\": {\"p50\": %.3f, \"p90\": %.3f, \"p99\": %.3f, \"max\": %.3f}}\n",
      opt.replicas, opt.busy_threads, ack_ms.size(), opt.rate, opt.bytes, Percentile(ack_ms, 0.5),
      Percentile(ack_ms, 0.9), Percentile(ack_ms, 0.99),
      *std::max_element(ack_ms.begin(), ack_ms.end()));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Time JetStream appends' acknowledgements (the replicated journal's floor)"};
  app.add_option("--servers", opt.servers, "NATS servers, comma-separated")->required();
  app.add_option("--stream", opt.stream, "stream to append to (created when missing)");
  app.add_option("--messages", opt.messages, "appends to time")->check(CLI::PositiveNumber);
  app.add_option("--rate", opt.rate, "appends per second")->check(CLI::PositiveNumber);
  app.add_option("--bytes", opt.bytes, "payload of each append")->check(CLI::PositiveNumber);
  app.add_option("--replicas", opt.replicas, "the stream's replicas")->check(CLI::Range(1, 5));
  app.add_option("--busy-threads", opt.busy_threads, "threads kept spinning meanwhile")
      ->check(CLI::Range(0, 64));
  CLI11_PARSE(app, argc, argv);
  return Run(opt);
}
