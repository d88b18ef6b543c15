// slamctl journal inspect|export (clients/slamctl/journal_export.h, journal_cmd.cc): a journal
// written through server/journal/journal.h with known messages exports to g2o files that
// core::ReadDataset reads back with the same measurements, and to an LCM log with the same
// channels, bytes and timestamps; inspect reports records, counts and a torn tail.
#include "clients/slamctl/journal_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <vector>

#include "core/factors/between_factor.h"
#include "core/factors/relative_point_factor.h"
#include "core/io/dataset.h"
#include "server/journal/journal.h"
#include "server/journal/read_journal.h"
#include "server/messages/inbound.h"
#include "slamd/landmark_observation_t.hpp"
#include "slamd/loop_closure_t.hpp"
#include "slamd/odometry_t.hpp"
#include "slamd/prior_t.hpp"
#include "slamd/remove_factor_t.hpp"
#include "tests/clients/slamctl/slamctl_runner.h"

namespace slamd::clients {
namespace {

namespace fs = std::filesystem;
using core::Pose2;
using core::Pose3;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("slamd_journal_export_" + std::to_string(::getpid()) + "_" + std::to_string(n_++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string str() const { return path_.string(); }

 private:
  static inline int n_ = 0;
  fs::path path_;
};

core::NoiseModel Cov2(double a, double b, double c) {
  Eigen::Matrix3d cov;
  cov << a, 0.01, 0.0, 0.01, b, 0.002, 0.0, 0.002, c;
  return core::NoiseModel::FromCovariance(cov).value();
}

struct Written {
  std::string channel;
  std::vector<std::uint8_t> bytes;
  std::int64_t wall_us;
};

// Appends `msg` to the journal as intake would, and remembers it.
template <typename Msg>
void Append(server::Journal& j, const std::string& channel, const char* type, const Msg& msg,
            std::vector<Written>* written) {
  std::vector<std::uint8_t> bytes(msg.getEncodedSize());
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const std::int64_t wall = 1700000000000000 + static_cast<std::int64_t>(written->size()) * 1000;
  ASSERT_TRUE(j.AppendMessage(channel, type, bytes, wall).ok());
  written->push_back({channel, bytes, wall});
}

// The journal of a small session: robot "a" (2D: prior, odometry 0->1->2->3, a loop closure,
// a repeated odometry, a relative-point and a bearing-range landmark, a loop closure that is
// retracted), robot "b" (3D odometry) and an a-b loop closure (not representable per robot).
// Boundaries and a refinement in between. Returns the journal path.
std::string WriteSession(const std::string& dir, std::vector<Written>* written) {
  auto j =
      server::Journal::Open(dir, {.writer = {.sync_policy = server::SyncPolicy::kNever}}, {}, 0)
          .value();
  using namespace server;
  slamd::prior_t prior;
  ToLcm(PriorMeasurement{1, "a", 0, PriorKind::kPose2, Pose2(1.0, 2.0, 0.5),
                         core::NoiseModel::Isotropic(3, 0.01).value()},
        &prior);
  Append(*j, "SLAMD_PRIOR", "prior_t", prior, written);
  const Pose2 steps[3] = {Pose2(1.0, 0.1, 0.2), Pose2(0.9, -0.1, 1.5), Pose2(1.2, 0.0, -0.3)};
  for (int i = 0; i < 3; ++i) {
    slamd::odometry_t odo;
    ToLcm(OdometryMeasurement{10 + i, "a", std::uint64_t(i), std::uint64_t(i + 1), steps[i],
                              Cov2(0.01 * (i + 1), 0.02, 0.003)},
          &odo);
    Append(*j, "SLAMD_ODOMETRY", "odometry_t", odo, written);
    if (i == 1) Append(*j, "SLAMD_ODOMETRY", "odometry_t", odo, written);  // a repeat
  }
  EXPECT_TRUE(j->AppendBoundary(1, 5, 5).ok());
  slamd::loop_closure_t lc;
  ToLcm(LoopClosureMeasurement{20, "a", 3, "a", 0, Pose2(-1.5, 2.0, 3.0), Cov2(0.1, 0.1, 0.01), {}},
        &lc);
  Append(*j, "SLAMD_LOOP_CLOSURE", "loop_closure_t", lc, written);
  slamd::loop_closure_t retracted;
  ToLcm(LoopClosureMeasurement{21, "a", 2, "a", 0, Pose2(0.5, 0.5, 0.5), Cov2(0.1, 0.1, 0.01), {}},
        &retracted);
  Append(*j, "SLAMD_LOOP_CLOSURE", "loop_closure_t", retracted, written);
  slamd::landmark_observation_t rp;
  ToLcm(LandmarkMeasurement{22, "a", 1, 7, LandmarkKind::kRelativePoint2, core::Point2(2.0, -1.0),
                            core::NoiseModel::Isotropic(2, 0.05).value()},
        &rp);
  Append(*j, "SLAMD_LANDMARK", "landmark_observation_t", rp, written);
  slamd::landmark_observation_t br;
  ToLcm(LandmarkMeasurement{23, "a", 2, 8, LandmarkKind::kBearingRange2, BearingRange{0.3, 4.0},
                            core::NoiseModel::Diagonal(Eigen::Vector2d(0.01, 0.1)).value()},
        &br);
  Append(*j, "SLAMD_LANDMARK", "landmark_observation_t", br, written);
  EXPECT_TRUE(j->AppendRefinement(3).ok());
  EXPECT_TRUE(j->AppendRebuildSwap(2, std::vector<int>{40, 6, 1}).ok());
  slamd::remove_factor_t rm;
  ToLcm(RemoveFactorRequest{.utime = 24,
                            .target = RemoveTarget::kLoopClosure,
                            .robot_a = "a",
                            .index_a = 0,
                            .robot_b = "a",
                            .index_b = 2},
        &rm);
  Append(*j, "SLAMD_REMOVE_FACTOR", "remove_factor_t", rm, written);
  slamd::odometry_t odo3;
  ToLcm(OdometryMeasurement{30, "b", 5, 6,
                            Pose3(core::Rot3::FromRollPitchYaw(0.1, 0.2, 0.3),
                                  core::Point3(1.0, 2.0, 3.0)),
                            core::NoiseModel::Isotropic(6, 0.1).value()},
        &odo3);
  Append(*j, "SLAMD_ODOMETRY", "odometry_t", odo3, written);
  slamd::loop_closure_t ab;
  ToLcm(LoopClosureMeasurement{31, "a", 1, "b", 5, Pose2(), Cov2(0.1, 0.1, 0.1), {}}, &ab);
  // (a 2D closure to a 3D robot: intake accepts it, the estimator would reject it)
  Append(*j, "SLAMD_LOOP_CLOSURE", "loop_closure_t", ab, written);
  EXPECT_TRUE(j->AppendBoundary(2, 12, 7).ok());
  EXPECT_TRUE(j->Sync().ok());
  return server::JournalSegmentPath(dir, 0);
}

template <typename T>
const T* As(const core::FactorPtr& f) {
  return dynamic_cast<const T*>(f.get());
}

void ExpectSameNoise(const core::NoiseModel& a, const core::NoiseModel& b) {
  EXPECT_LE((a.Covariance() - b.Covariance()).lpNorm<Eigen::Infinity>(),
            1e-12 * (1.0 + a.Covariance().lpNorm<Eigen::Infinity>()));
}

TEST(JournalExportTest, G2oReadsBackWithTheSameMeasurements) {
  TempDir dir, out;
  std::vector<Written> written;
  const std::string path = WriteSession(dir.str(), &written);
  core::Result<JournalExportResult> r = ExportJournal(path, out.str());
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const JournalExportResult& e = r.value();
  EXPECT_EQ(e.messages, static_cast<std::int64_t>(written.size()));
  EXPECT_EQ(e.duplicates, 1);
  EXPECT_EQ(e.removed, 1);
  ASSERT_EQ(e.g2o.size(), 2u);
  EXPECT_EQ(e.exported_factors, 3 + 1 + 2 + 1);  // a: odometry, loop, 2 landmarks; b: odometry
  bool noted_cross_robot = false;
  for (const std::string& n : e.notes) {
    noted_cross_robot |= n.find("between two robots") != std::string::npos;
  }
  EXPECT_TRUE(noted_cross_robot);

  // Robot a, 2D.
  core::Result<core::Dataset> a = core::ReadDataset(e.g2o.at("a"));
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  const core::Dataset& da = a.value();
  EXPECT_FALSE(da.is_3d);
  ASSERT_EQ(da.graph.size(), 6u);
  // Graph order = journal order: 3 odometry, loop closure, relative point, bearing range.
  const Pose2 steps[3] = {Pose2(1.0, 0.1, 0.2), Pose2(0.9, -0.1, 1.5), Pose2(1.2, 0.0, -0.3)};
  for (int i = 0; i < 3; ++i) {
    const auto* b = As<core::BetweenFactor<Pose2>>(da.graph.factors()[i]);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->keys()[0], core::MakeKey('x', i));
    EXPECT_EQ(b->keys()[1], core::MakeKey('x', i + 1));
    EXPECT_NEAR(b->measured().x(), steps[i].x(), 1e-12);
    EXPECT_NEAR(b->measured().y(), steps[i].y(), 1e-12);
    EXPECT_NEAR(b->measured().theta(), steps[i].theta(), 1e-12);
    ExpectSameNoise(b->noise_model(), Cov2(0.01 * (i + 1), 0.02, 0.003));
  }
  const auto* loop = As<core::BetweenFactor<Pose2>>(da.graph.factors()[3]);
  ASSERT_NE(loop, nullptr);
  EXPECT_EQ(loop->keys()[0], core::MakeKey('x', 3));
  EXPECT_EQ(loop->keys()[1], core::MakeKey('x', 0));
  EXPECT_NEAR(loop->measured().theta(), 3.0, 1e-12);
  const auto* rp = As<core::RelativePointFactor<Pose2, core::Point2>>(da.graph.factors()[4]);
  ASSERT_NE(rp, nullptr);
  EXPECT_EQ(rp->keys()[1], core::MakeKey('l', 7));
  EXPECT_NEAR(rp->measured().x(), 2.0, 1e-12);
  EXPECT_NEAR(rp->measured().y(), -1.0, 1e-12);
  ExpectSameNoise(rp->noise_model(), core::NoiseModel::Isotropic(2, 0.05).value());
  const auto* br = As<core::RelativePointFactor<Pose2, core::Point2>>(da.graph.factors()[5]);
  ASSERT_NE(br, nullptr);
  EXPECT_NEAR(br->measured().x(), 4.0 * std::cos(0.3), 1e-12);
  EXPECT_NEAR(br->measured().y(), 4.0 * std::sin(0.3), 1e-12);
  // First-order covariance of (r cos b, r sin b): J diag(σb², σr²) Jᵀ.
  Eigen::Matrix2d J;
  J << -4.0 * std::sin(0.3), std::cos(0.3), 4.0 * std::cos(0.3), std::sin(0.3);
  const Eigen::Matrix2d want = J * Eigen::Vector2d(1e-4, 1e-2).asDiagonal() * J.transpose();
  EXPECT_LE((br->noise_model().Covariance() - want).lpNorm<Eigen::Infinity>(), 1e-12);
  // Vertices: the prior's pose, composed along the odometry, and FIX on the prior's pose.
  const Pose2& x0 = da.initial.At<Pose2>(core::MakeKey('x', 0));
  EXPECT_NEAR(x0.x(), 1.0, 1e-12);
  EXPECT_NEAR(x0.theta(), 0.5, 1e-12);
  const Pose2 x2 = Pose2(1.0, 2.0, 0.5) * steps[0] * steps[1];
  EXPECT_NEAR(da.initial.At<Pose2>(core::MakeKey('x', 2)).x(), x2.x(), 1e-12);
  ASSERT_EQ(da.fixed.size(), 1u);
  EXPECT_EQ(da.fixed[0], core::MakeKey('x', 0));

  // Robot b, 3D.
  core::Result<core::Dataset> b = core::ReadDataset(e.g2o.at("b"));
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  EXPECT_TRUE(b.value().is_3d);
  ASSERT_EQ(b.value().graph.size(), 1u);
  const auto* b3 = As<core::BetweenFactor<Pose3>>(b.value().graph.factors()[0]);
  ASSERT_NE(b3, nullptr);
  EXPECT_NEAR(b3->measured().translation().z(), 3.0, 1e-12);
  EXPECT_EQ(b3->keys()[0], core::MakeKey('x', 5));
}

TEST(JournalExportTest, LcmLogHasTheJournaledChannelsBytesAndTimes) {
  TempDir dir, out;
  std::vector<Written> written;
  const std::string path = WriteSession(dir.str(), &written);
  core::Result<JournalExportResult> r = ExportJournal(path, out.str(), {.g2o = false});
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_TRUE(r.value().g2o.empty());
  lcm::LogFile log(r.value().lcm_log, "r");
  ASSERT_TRUE(log.good());
  size_t i = 0;
  for (const lcm::LogEvent* ev = log.readNextEvent(); ev != nullptr; ev = log.readNextEvent()) {
    ASSERT_LT(i, written.size());
    EXPECT_EQ(ev->channel, written[i].channel);
    EXPECT_EQ(ev->timestamp, written[i].wall_us);
    const auto* data = static_cast<const std::uint8_t*>(ev->data);
    EXPECT_EQ(std::vector<std::uint8_t>(data, data + ev->datalen), written[i].bytes);
    ++i;
  }
  EXPECT_EQ(i, written.size());
}

TEST(JournalExportTest, InspectListsRecordsAndReportsATornTail) {
  TempDir dir;
  std::vector<Written> written;
  const std::string path = WriteSession(dir.str(), &written);
  core::Result<JournalInspection> r = InspectJournal(path, false);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const JournalInspection& in = r.value();
  EXPECT_EQ(in.messages, static_cast<std::int64_t>(written.size()));
  EXPECT_EQ(in.boundaries, 2);
  EXPECT_EQ(in.refinements, 1);
  EXPECT_EQ(in.rebuild_swaps, 1);
  EXPECT_EQ(in.end, "clean");
  EXPECT_EQ(in.messages_by_type.at("odometry_t"), 5);
  ASSERT_EQ(in.records.size(), written.size() + 4);
  int swaps = 0;
  for (const JournalRecordInfo& rec : in.records) {
    if (rec.kind != "rebuild") continue;
    ++swaps;
    EXPECT_EQ(rec.sequence, 2);
    EXPECT_EQ(rec.detail, "catch_up_rounds=40,6,1");
  }
  EXPECT_EQ(swaps, 1);
  EXPECT_EQ(in.records[0].offset, 16);
  EXPECT_EQ(in.records[0].kind, "message");
  EXPECT_EQ(in.records[0].sequence, 1);
  EXPECT_EQ(in.records[0].type, "prior_t");
  EXPECT_EQ(in.records[0].robot, "a");
  for (size_t i = 0; i + 1 < in.records.size(); ++i) {
    EXPECT_EQ(in.records[i].offset + in.records[i].size, in.records[i + 1].offset);
  }
  EXPECT_EQ(in.records.back().offset + in.records.back().size, in.file_size);
  const JournalRecordInfo& last = in.records.back();
  EXPECT_EQ(last.kind, "boundary");
  EXPECT_EQ(last.sequence, 2);

  // Cut the file inside its last record: a torn tail at that record's offset.
  fs::resize_file(path, static_cast<std::uintmax_t>(last.offset + last.size / 2));
  core::Result<JournalInspection> torn = InspectJournal(path, false);
  ASSERT_TRUE(torn.ok());
  EXPECT_EQ(torn.value().end, "torn tail");
  EXPECT_EQ(torn.value().torn_tail_offset, last.offset);
  EXPECT_EQ(torn.value().records.size(), in.records.size() - 1);
  EXPECT_NE(
      FormatInspection(torn.value()).find("torn tail at offset " + std::to_string(last.offset)),
      std::string::npos);
  const std::string json = InspectionJson(torn.value());
  EXPECT_NE(json.find("\"end\": \"torn tail\""), std::string::npos) << json;

  // Through the binary: exit 0 with the tail reported; export still works.
  testing::SlamctlRun run = testing::RunSlamctl("journal inspect " + path);
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find("torn tail"), std::string::npos) << run.out;
  run = testing::RunSlamctl("journal inspect --json " + path);
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_EQ(run.out.front(), '{') << run.out;
  EXPECT_NE(run.out.find("\"records\": [{\"offset\": 16, \"kind\": \"message\""), std::string::npos)
      << run.out;
  TempDir out;
  run = testing::RunSlamctl("journal export " + path + " -o " + out.str() + "/x");
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_TRUE(fs::exists(out.str() + "/x/journal.lcmlog")) << run.out;
  EXPECT_TRUE(fs::exists(out.str() + "/x/a.g2o")) << run.out;
}

// A data directory whose journal spans segments, the oldest deleted: inspect and export read
// them as one journal from where it starts, with global offsets; `slamctl journal inspect DIR`.
TEST(JournalExportTest, ReadsAJournalOfSeveralSegments) {
  TempDir dir;
  fs::create_directories(dir.str());
  std::vector<Written> written;
  std::int64_t first_kept = 0;  // the first message of the second segment
  {
    auto j =
        server::Journal::Open(
            dir.str(),
            {.writer = {.sync_policy = server::SyncPolicy::kNever}, .segment_bytes = 4096}, {}, 0)
            .value();
    for (int i = 0; i < 80; ++i) {
      slamd::odometry_t odo;
      ToLcm(server::OdometryMeasurement{i, "a", std::uint64_t(i), std::uint64_t(i + 1),
                                        Pose2(1.0, 0.0, 0.1), Cov2(0.01, 0.02, 0.003)},
            &odo);
      Append(*j, "SLAMD_ODOMETRY", "odometry_t", odo, &written);
    }
    ASSERT_GT(j->segments(), 3);
    ASSERT_TRUE(j->Sync().ok());
    const server::JournalContents c = server::ReadJournal(dir.str()).value();
    first_kept = c.segments[0].last_message_sequence + 1;
    ASSERT_EQ(j->DeleteCovered(first_kept - 1, c.segments[1].base).value(), 1);
  }
  const JournalInspection in = InspectJournal(dir.str(), false).value();
  EXPECT_EQ(in.end, "clean");
  EXPECT_GT(in.first_offset, 0);
  EXPECT_EQ(in.records.front().offset, in.first_offset + 16);
  EXPECT_EQ(in.records.front().sequence, first_kept);
  EXPECT_EQ(in.messages, 81 - first_kept);
  EXPECT_LT(in.disk_bytes, in.file_size);
  for (size_t i = 0; i + 1 < in.records.size(); ++i) {
    EXPECT_GT(in.records[i + 1].offset, in.records[i].offset);
  }
  const testing::SlamctlRun run = testing::RunSlamctl("journal inspect " + dir.str() + " --json");
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find("\"segments\": " + std::to_string(in.segments)), std::string::npos)
      << run.out.substr(0, 300);
}

TEST(JournalExportTest, CorruptionInTheMiddleIsReportedAndBadArgumentsExit2) {
  TempDir dir;
  std::vector<Written> written;
  const std::string path = WriteSession(dir.str(), &written);
  const JournalInspection in = InspectJournal(path, false).value();
  {  // flip a byte inside the third record's payload
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(in.records[2].offset + in.records[2].size - 3);
    f.put('\x5a' ^ static_cast<char>(f.peek()));
  }
  core::Result<JournalInspection> bad = InspectJournal(path, false);
  ASSERT_TRUE(bad.ok());
  EXPECT_EQ(bad.value().end, "corruption");
  EXPECT_EQ(bad.value().records.size(), 2u);
  core::Result<JournalInspection> salvaged = InspectJournal(path, true);
  ASSERT_TRUE(salvaged.ok());
  EXPECT_EQ(salvaged.value().records.size(), in.records.size() - 1);
  EXPECT_EQ(salvaged.value().skipped.size(), 1u);
  TempDir out;
  EXPECT_FALSE(ExportJournal(path, out.str()).ok());
  EXPECT_TRUE(ExportJournal(path, out.str(), {.salvage = true}).ok());

  EXPECT_EQ(testing::RunSlamctl("journal inspect " + path).exit_code, 1);
  EXPECT_EQ(testing::RunSlamctl("journal inspect --salvage " + path).exit_code, 0);
  EXPECT_EQ(testing::RunSlamctl("journal").exit_code, 2);
  EXPECT_EQ(testing::RunSlamctl("journal inspect").exit_code, 2);
  EXPECT_EQ(testing::RunSlamctl("journal inspect /nonexistent/journal.slamdj").exit_code, 2);
  EXPECT_EQ(testing::RunSlamctl("journal export " + path).exit_code, 2);  // no -o
  EXPECT_EQ(
      testing::RunSlamctl("journal export " + path + " -o " + out.str() + " --no-g2o --no-lcm-log")
          .exit_code,
      2);
  EXPECT_EQ(testing::RunSlamctl("journal frobnicate " + path).exit_code, 2);
}

}  // namespace
}  // namespace slamd::clients
