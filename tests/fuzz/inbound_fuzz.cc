// Fuzz target: the daemon's inbound path for every inbound LCM type. DecodeInbound(type, bytes)
// is exactly what live intake does (typed_subscribe.h internal::DecodeAs, then conversion.h
// Convert, which validates) and what journal recovery does with stored bytes.
//
// Input: byte 0 selects the type (low bits, modulo 6) and whether to go further (bit 7); the
// rest is the LCM encoding (8-byte fingerprint first). Properties checked:
//   1. DecodeInbound never crashes, whatever the bytes (sanitizers catch the rest).
//   2. An accepted message re-encodes (EncodeInbound, what snapshots store for held messages)
//      to bytes that are accepted again (else a snapshot could not be restored).
//   3. With bit 7 set, an accepted measurement is applied by a fresh Estimator after a small
//      valid prelude (anchor prior, odometry for robots "alpha" and "bravo"): Process must not
//      crash, whatever the values (a rejection or a Status is fine).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/isam/isam2.h"
#include "server/estimator/estimator.h"
#include "server/messages/inbound_codec.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::server {
namespace {

core::NoiseModel Noise(int dim) { return core::NoiseModel::Isotropic(dim, 0.1).value(); }

// Poses 0..5 of "alpha" (anchored by a prior) and 0..3 of "bravo" (2D), so that fuzzed indices
// near the seeds' (4, 5, 100, 3, 17) hit existing, next and far-ahead poses.
std::vector<Inbound> Prelude() {
  std::vector<Inbound> m;
  m.push_back(
      {PriorMeasurement{1, "alpha", 0, PriorKind::kPose2, core::Pose2(0, 0, 0), Noise(3)}, 0});
  for (std::uint64_t i = 0; i < 5; ++i) {
    m.push_back({OdometryMeasurement{2, "alpha", i, i + 1, core::Pose2(1, 0, 0.1), Noise(3)}, 0});
  }
  m.push_back(
      {PriorMeasurement{3, "bravo", 0, PriorKind::kPose2, core::Pose2(5, 5, 1), Noise(3)}, 0});
  for (std::uint64_t i = 0; i < 3; ++i) {
    m.push_back({OdometryMeasurement{4, "bravo", i, i + 1, core::Pose2(0.5, 0, 0), Noise(3)}, 0});
  }
  return m;
}

void RunInbound(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return;
  const std::vector<std::string>& types = InboundTypeNames();
  const std::string type = types[(data[0] & 0x7F) % types.size()];
  const bool process = (data[0] & 0x80) != 0;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);

  core::Result<Inbound> in = DecodeInbound(type, bytes);  // 1.
  if (!in.ok()) return;

  std::string type_again;  // 2.
  const std::vector<std::uint8_t> again = EncodeInbound(in.value(), &type_again);
  if (type_again != type) fuzz::Fail("EncodeInbound type " + type_again + " != " + type);
  core::Result<Inbound> in2 = DecodeInbound(type_again, again);
  if (!in2.ok()) {
    fuzz::Fail("accepted " + type +
               " not accepted after EncodeInbound: " + in2.status().ToString());
  }

  if (!process || std::holds_alternative<QueryRequest>(in.value().measurement)) return;  // 3.
  core::Isam2Params isam2;
  auto estimator = Estimator::Create({}, isam2);
  if (!estimator.ok()) fuzz::Fail("Estimator::Create: " + estimator.status().ToString());
  std::vector<Inbound> batch = Prelude();
  const ProcessResult prelude = estimator.value()->Process(batch);
  if (!prelude.status.ok() || !prelude.rejections.empty()) fuzz::Fail("prelude not applied");
  estimator.value()->Process({std::move(in).value()});
}

}  // namespace
}  // namespace slamd::server

namespace slamd::fuzz {
void FuzzInbound(const std::uint8_t* data, std::size_t size) { server::RunInbound(data, size); }
}  // namespace slamd::fuzz

SLAMD_FUZZ_ENTRY_POINT(slamd::fuzz::FuzzInbound)
