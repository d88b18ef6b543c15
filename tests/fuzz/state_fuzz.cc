// Fuzz target: snapshot states. DecodeState (server/snapshot/state_codec.h) of arbitrary bytes,
// then Estimator::Restore of every state that decodes, then one Process of a small batch on the
// restored estimator. Property: none of it crashes; an inconsistent state must give a Status
// ("state restore must never crash"). The bytes are those a snapshot file holds after its
// frame and checksum (snapshot_file.h), i.e. what a corrupted-but-checksummed or hand-made
// snapshot can contain.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "core/isam/isam2.h"
#include "server/estimator/estimator.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "tests/fuzz/fuzz_util.h"

namespace slamd::fuzz {

void FuzzState(const std::uint8_t* data, std::size_t size) {
  using namespace slamd::server;  // NOLINT: a fuzz entry point
  JournalPosition position;
  slamd::core::Result<EstimatorState> state =
      DecodeState(std::string_view(reinterpret_cast<const char*>(data), size), &position);
  if (!state.ok()) return;
  slamd::core::Isam2Params isam2;  // default params, as the seeds were made with
  auto restored = Estimator::Restore({}, isam2, state.value());
  if (!restored.ok()) return;
  const auto noise = slamd::core::NoiseModel::Isotropic(3, 0.1).value();
  std::vector<Inbound> batch = {
      {OdometryMeasurement{1, "r", 5, 6, slamd::core::Pose2(1, 0, 0.1), noise}, 0},
      {RemoveFactorRequest{2, RemoveTarget::kOdometry, "r", 0, "", 1, 0}, 0}};
  (void)restored.value()->Process(std::move(batch));
}

}  // namespace slamd::fuzz

SLAMD_FUZZ_ENTRY_POINT(slamd::fuzz::FuzzState)
