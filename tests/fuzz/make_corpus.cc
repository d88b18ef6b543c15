// Writes the generated seeds of the fuzz corpus (tests/fuzz/corpus/{inbound,journal,state}/):
// encoded messages, journal chunks and snapshot states built from the same valid examples the
// unit tests use. Run by hand after a format change (scripts/fuzz --make-corpus); the dataset
// and config seeds are plain text files kept in the tree.
//   make_corpus <corpus dir>
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/isam/isam2.h"
#include "server/estimator/estimator.h"
#include "server/journal/journal_format.h"
#include "server/messages/inbound.h"
#include "server/messages/inbound_codec.h"
#include "server/snapshot/estimator_state.h"
#include "server/snapshot/state_codec.h"
#include "slamd_proto/journal.pb.h"
#include "tests/fuzz/fuzz_util.h"
#include "tests/server/ingest/test_messages.h"

namespace slamd::server {
namespace {

namespace t = testing;
namespace fs = std::filesystem;

template <typename Msg>
std::string Encode(const Msg& msg) {
  std::string bytes(static_cast<size_t>(msg.getEncodedSize()), '\0');
  if (msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) !=
      static_cast<int>(bytes.size())) {
    fuzz::Fail("encode");
  }
  return bytes;
}

// (type name, LCM bytes) of every example message.
struct Example {
  std::string name;
  std::string bytes;
};

std::vector<Example> Examples() {
  std::vector<Example> e;
  e.push_back({"odometry_t", Encode(t::Odometry2())});
  e.push_back({"odometry_t", Encode(t::Odometry3())});
  for (int kind = 1; kind <= 3; ++kind) {
    e.push_back({"landmark_observation_t", Encode(t::Landmark(kind))});
  }
  e.push_back({"loop_closure_t", Encode(t::LoopClosure2())});
  e.push_back({"loop_closure_t", Encode(t::LoopClosure3())});
  for (int kind = 1; kind <= 4; ++kind) e.push_back({"prior_t", Encode(t::Prior(kind))});
  for (int target = 1; target <= 4; ++target) {
    e.push_back({"remove_factor_t", Encode(t::RemoveFactor(target))});
  }
  e.push_back({"query_t", Encode(t::Query())});
  for (int model = 1; model <= 4; ++model) {
    e.push_back({"camera_info_t", Encode(t::CameraInfoMessage(model))});
  }
  e.push_back({"frame_observations_t", Encode(t::FrameMessage(1))});
  e.push_back({"frame_observations_t", Encode(t::FrameMessage(2, true))});
  return e;
}

void Write(const fs::path& dir, const std::string& name, const std::string& bytes) {
  fs::create_directories(dir);
  fuzz::WriteFileOrDie((dir / name).string(), bytes);
}

std::string Chunk(std::uint8_t tag, const std::string& payload) {
  std::string c(1, static_cast<char>(tag));
  c += static_cast<char>(payload.size() & 0xFF);
  c += static_cast<char>((payload.size() >> 8) & 0xFF);
  return c + payload;
}

std::vector<Inbound> StateMessages() {
  const auto noise = core::NoiseModel::Isotropic(3, 0.1).value();
  std::vector<Inbound> m;
  m.push_back({PriorMeasurement{1, "r", 0, PriorKind::kPose2, core::Pose2(1, 2, 0.3), noise}, 0});
  for (std::uint64_t i = 0; i < 5; ++i) {
    m.push_back({OdometryMeasurement{2, "r", i, i + 1, core::Pose2(1, 0.1, 0.2), noise}, 0});
  }
  m.push_back({LandmarkMeasurement{3, "r", 3, 8, LandmarkKind::kRelativePoint2, core::Point2(1, -1),
                                   core::NoiseModel::Isotropic(2, 0.05).value()},
               0});
  m.push_back({LoopClosureMeasurement{
                   5, "r", 5, "r", 1, core::Pose2(-3, 0.5, -0.6), noise,
                   core::RobustKernel::Create(core::RobustKernel::Kind::kCauchy, 1.0).value()},
               0});
  m.push_back({OdometryMeasurement{7, "s", 0, 1, core::Pose2(1, 0, 0), noise}, 0});   // held
  m.push_back({OdometryMeasurement{11, "r", 7, 8, core::Pose2(1, 0, 0), noise}, 0});  // held
  // A camera robot: its camera, and a frame whose landmark waits in its track (one view).
  m.push_back({PriorMeasurement{12, "c", 0, PriorKind::kPose3, core::Pose3(),
                                core::NoiseModel::Isotropic(6, 0.01).value()},
               0});
  m.push_back({Convert(t::CameraInfoMessage(1)).value(), 0});
  std::get<CameraInfo>(m.back().measurement).robot = "c";
  std::get<CameraInfo>(m.back().measurement).camera_id = 0;
  FrameObservations frame = Convert(t::FrameMessage(1)).value();
  frame.robot = "c";
  frame.pose_index = 0;
  frame.camera_id = 0;
  m.push_back({frame, 0});
  return m;
}

void Run(const fs::path& corpus) {
  const std::vector<Example> examples = Examples();
  // inbound: selector byte + bytes; bit 7 (process in an estimator) on every other seed.
  for (size_t i = 0; i < examples.size(); ++i) {
    // inbound_fuzz.cc picks the type by its position in the list.
    const std::vector<std::string>& types = InboundTypeNames();
    const int type =
        static_cast<int>(std::find(types.begin(), types.end(), examples[i].name) - types.begin());
    const char selector = static_cast<char>(type | (i % 2 == 0 ? 0x80 : 0));
    Write(corpus / "inbound", "seed_" + std::to_string(i), selector + examples[i].bytes);
  }
  // journal: layout 2 (header + chunks), with and without salvage.
  std::string chunks;
  for (size_t i = 0; i < examples.size(); i += 3) {
    journal::JournalRecord record;
    record.mutable_message()->set_sequence(static_cast<int64_t>(i + 1));
    record.mutable_message()->set_channel("SLAMD_IN");
    record.mutable_message()->set_message_type(examples[i].name);
    record.mutable_message()->set_lcm_payload(examples[i].bytes);
    chunks += Chunk(0, record.SerializeAsString());
  }
  journal::JournalRecord boundary;
  boundary.mutable_boundary()->set_update_sequence(1);
  boundary.mutable_boundary()->set_last_message_sequence(static_cast<int64_t>(examples.size()));
  boundary.mutable_boundary()->set_message_count(5);
  chunks += Chunk(0, boundary.SerializeAsString());
  journal::JournalRecord refinement;
  refinement.mutable_refinement()->set_rounds(2);
  chunks += Chunk(0, refinement.SerializeAsString());
  Write(corpus / "journal", "seed_clean", std::string(1, 4) + chunks);
  Write(corpus / "journal", "seed_torn",
        std::string(1, 4) + chunks + Chunk(1, std::string("\x20\0\0\0xyz", 8)));
  Write(corpus / "journal", "seed_middle_salvage",
        std::string(1, 5) + Chunk(1, "garbage!") + chunks);
  Write(corpus / "journal", "seed_header_only", std::string(1, 2));
  Write(corpus / "journal", "seed_raw_header", std::string(1, 0) + internal::EncodeJournalHeader());
  // state: an estimator with every factor kind of the prelude, a held message, two robots.
  core::Isam2Params isam2;
  auto e = Estimator::Create({}, isam2).value();
  const ProcessResult r = e->Process(StateMessages());
  if (!r.status.ok()) fuzz::Fail("state messages: " + r.status.ToString());
  Write(corpus / "state", "seed_state", EncodeState(e->ExportState(), {3, 100}));
  auto empty = Estimator::Create({}, isam2).value();
  Write(corpus / "state", "seed_empty", EncodeState(empty->ExportState(), {}));
}

}  // namespace
}  // namespace slamd::server

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_corpus <corpus dir>\n");
    return 2;
  }
  slamd::server::Run(argv[1]);
  return 0;
}
