#include "clients/slamctl/journal_export.h"

#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>
#include <utility>
#include <variant>

#include "clients/slamctl/json_writer.h"
#include "core/io/dataset.h"
#include "server/journal/journal_segments.h"
#include "server/messages/inbound_codec.h"
#include "slamd_proto/journal.pb.h"

namespace slamd::clients {
namespace {

namespace fs = std::filesystem;
using server::Inbound;

const char* RecordKind(const journal::JournalRecord& r) {
  if (r.has_message()) return "message";
  if (r.has_boundary()) return "boundary";
  if (r.has_refinement()) return "refinement";
  if (r.has_rebuild_swap()) return "rebuild";
  if (r.has_removal()) return "removal";
  return "unknown";
}

std::span<const std::uint8_t> Bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// Streams the records of `path` to `on_record(record, offset, frame_size)`; fills the end state.
core::Status ReadRecords(const std::string& path, bool salvage, JournalInspection* out,
                         const std::function<void(const journal::JournalRecord&, std::int64_t,
                                                  std::int64_t)>& on_record) {
  core::Result<std::unique_ptr<server::SegmentedJournalReader>> opened =
      server::SegmentedJournalReader::Open(path, {.salvage = salvage});
  SLAMD_RETURN_IF_ERROR(opened.status());
  server::SegmentedJournalReader& reader = *opened.value();
  journal::JournalRecord record;
  std::int64_t offset = 0;
  server::JournalReadState state;
  while ((state = reader.Next(&record, &offset)) == server::JournalReadState::kRecord) {
    on_record(record, offset, reader.valid_end_offset() - offset);
  }
  out->file_size = reader.end_offset();
  out->disk_bytes = reader.disk_bytes();
  out->segments = static_cast<int>(reader.segments().size());
  out->first_offset = reader.first_offset();
  out->valid_end_offset = reader.valid_end_offset();
  out->skipped_bytes = reader.skipped_bytes();
  for (const server::SkippedRegion& s : reader.skipped_regions()) {
    out->skipped.push_back(std::to_string(s.offset) + " +" + std::to_string(s.length) + ": " +
                           s.reason);
  }
  switch (state) {
    case server::JournalReadState::kTornTail:
      out->end = "torn tail";
      out->torn_tail_offset = reader.torn_tail_offset();
      out->end_reason = reader.end_reason();
      break;
    case server::JournalReadState::kError:
      if (reader.error().code() != core::StatusCode::kDataLoss) return reader.error();
      out->end = "corruption";
      out->corruption = reader.error().message();
      out->end_reason = reader.end_reason();
      break;
    default:
      out->end = "clean";
  }
  return core::Status();
}

// ---- export: measurements into per-robot datasets ----

// A measurement's identity, as the estimator's duplicate rule and remove_factor_t name it
// (server/messages/message_spec.h), with robots by name: (the spec's kIdentity letter, robot_a,
// index_a, robot_b, index_b, kind); loop closures ordered. The factors are the specs' own.
using MeasurementId = std::tuple<char, std::string, std::uint64_t, std::string, std::uint64_t, int>;

MeasurementId LoopId(std::string ra, std::uint64_t a, std::string rb, std::uint64_t b) {
  if (std::tie(rb, b) < std::tie(ra, a)) {
    std::swap(ra, rb);
    std::swap(a, b);
  }
  return {server::LoopClosureSpec::kIdentity, std::move(ra), a, std::move(rb), b, 0};
}

struct RobotGraph {
  std::optional<bool> is_3d;
  std::vector<core::FactorPtr> factors;            // null once retracted
  std::map<std::uint64_t, core::Variable> priors;  // pose index -> prior value (first wins)
  std::set<std::uint64_t> poses, landmarks;
};

class Exporter {
 public:
  explicit Exporter(JournalExportResult* result) : result_(result) {}
  std::int64_t bearing_range() const { return bearing_range_; }

  void Add(const Inbound& in) {
    std::visit([&](const auto& m) { AddMeasurement(m); }, in.measurement);
  }

  core::Status Write(const std::string& dir) {
    for (auto& [robot, g] : robots_) {
      core::Dataset data;
      data.is_3d = g.is_3d.value_or(false);
      for (const core::FactorPtr& f : g.factors) {
        if (f) data.graph.Add(f);
      }
      if (data.graph.size() == 0 && g.priors.empty()) continue;
      SLAMD_RETURN_IF_ERROR(Initialise(robot, g, &data));
      const std::string path = dir + "/" + robot + ".g2o";
      SLAMD_RETURN_IF_ERROR(core::WriteG2o(data, path));
      result_->g2o[robot] = path;
      result_->exported_factors += static_cast<std::int64_t>(data.graph.size());
    }
    for (const auto& [what, count] : skipped_) {
      result_->notes.push_back(std::to_string(count) + " " + what +
                               " not in the g2o files (they are in the LCM log)");
    }
    return core::Status();
  }

 private:
  static core::Key Pose(std::uint64_t i) { return core::MakeKey('x', i); }
  static core::Key Landmark(std::uint64_t j) { return core::MakeKey('l', j); }

  void Skip(const std::string& what) { ++skipped_[what]; }

  // False (and counted) when `id` is already applied.
  bool Admit(const MeasurementId& id, const std::string& robot, core::FactorPtr factor) {
    if (live_.count(id)) {
      ++result_->duplicates;
      return false;
    }
    RobotGraph& g = robots_[robot];
    live_[id] = {robot, g.factors.size()};
    g.factors.push_back(std::move(factor));
    return true;
  }

  // Marks the robot 2D or 3D; false (counted) on a mismatch with its earlier measurements.
  bool Dims(const std::string& robot, bool is_3d) {
    RobotGraph& g = robots_[robot];
    if (!g.is_3d) g.is_3d = is_3d;
    if (*g.is_3d == is_3d) return true;
    Skip(std::string("measurements of robot '") + robot + "' with a different dimension");
    return false;
  }

  void AddMeasurement(const server::OdometryMeasurement& m) {
    const bool is_3d = std::holds_alternative<core::Pose3>(m.measured);
    if (!Dims(m.robot, is_3d)) return;
    if (Admit({server::OdometrySpec::kIdentity, m.robot, m.from_index, "", m.to_index, 0}, m.robot,
              server::OdometrySpec::Factor(m, Pose(m.from_index), Pose(m.to_index)))) {
      robots_[m.robot].poses.insert({m.from_index, m.to_index});
    }
  }

  void AddMeasurement(const server::LoopClosureMeasurement& m) {
    if (m.robot_a != m.robot_b) {
      Skip("loop closures between two robots");
      return;
    }
    const bool is_3d = std::holds_alternative<core::Pose3>(m.measured);
    if (!Dims(m.robot_a, is_3d)) return;
    if (Admit(LoopId(m.robot_a, m.pose_a, m.robot_b, m.pose_b), m.robot_a,
              server::LoopClosureSpec::Factor(m, Pose(m.pose_a), Pose(m.pose_b), {}))) {
      robots_[m.robot_a].poses.insert({m.pose_a, m.pose_b});
    }
  }

  void AddMeasurement(const server::LandmarkMeasurement& m) {
    if (m.kind == server::LandmarkKind::kRelativePoint3) {
      Skip("3D landmark observations");
      return;
    }
    if (m.landmark_namespace == server::LandmarkNamespace::kMap) {  // ties robots together
      Skip("observations of the shared map's landmarks");
      return;
    }
    if (!Dims(m.robot, false)) return;
    server::LandmarkMeasurement point = m;  // as a relative point: g2o has no bearing-range
    if (const auto* br = std::get_if<server::BearingRange>(&m.measured)) {
      // p = r (cos b, sin b); first-order covariance J Σ Jᵀ, J = ∂p/∂(b, r).
      const double c = std::cos(br->bearing), s = std::sin(br->bearing), r = br->range;
      point.measured = core::Point2(r * c, r * s);
      point.kind = server::LandmarkKind::kRelativePoint2;
      Eigen::Matrix2d J;
      J << -r * s, c, r * c, s;
      core::Result<core::NoiseModel> converted =
          core::NoiseModel::FromCovariance(J * m.noise.Covariance() * J.transpose());
      if (!converted.ok()) {
        Skip("bearing-range observations at zero range");
        return;
      }
      point.noise = converted.value();
      ++bearing_range_;
    }
    if (Admit({server::LandmarkObservationSpec::kIdentity, m.robot, m.pose_index, "", m.landmark_id,
               static_cast<int>(m.kind)},
              m.robot,
              server::LandmarkObservationSpec::Factor(point, Pose(m.pose_index),
                                                      Landmark(m.landmark_id)))) {
      robots_[m.robot].poses.insert(m.pose_index);
      robots_[m.robot].landmarks.insert(m.landmark_id);
    }
  }

  void AddMeasurement(const server::PriorMeasurement& m) {
    if (m.kind == server::PriorKind::kPosition2 || m.kind == server::PriorKind::kPosition3) {
      Skip("position priors");
      return;
    }
    const bool is_3d = m.kind == server::PriorKind::kPose3;
    if (!Dims(m.robot, is_3d)) return;
    const MeasurementId id{server::PriorSpec::kIdentity, m.robot, m.pose_index, "", 0,
                           static_cast<int>(m.kind)};
    if (live_.count(id)) {
      ++result_->duplicates;
      return;
    }
    live_[id] = {m.robot, kNoFactor};
    RobotGraph& g = robots_[m.robot];
    if (is_3d) {
      g.priors.emplace(m.pose_index, std::get<core::Pose3>(m.measured));
    } else {
      g.priors.emplace(m.pose_index, std::get<core::Pose2>(m.measured));
    }
    g.poses.insert(m.pose_index);
  }

  void AddMeasurement(const server::RemoveFactorRequest& r) {
    MeasurementId id;
    switch (r.target) {
      case server::RemoveTarget::kOdometry:
        id = {server::OdometrySpec::kIdentity, r.robot_a, r.index_a, "", r.index_b, 0};
        break;
      case server::RemoveTarget::kLandmarkObservation:
        id = {server::LandmarkObservationSpec::kIdentity,
              r.robot_a,
              r.index_a,
              "",
              r.index_b,
              r.kind};
        break;
      case server::RemoveTarget::kLoopClosure:
        id = LoopId(r.robot_a, r.index_a, r.robot_b, r.index_b);
        break;
      case server::RemoveTarget::kPrior:
        id = {server::PriorSpec::kIdentity, r.robot_a, r.index_a, "", 0, r.kind};
        break;
      case server::RemoveTarget::kMapLandmarkObservation:
        return;  // the shared map's observations are not exported
    }
    const auto it = live_.find(id);
    if (it == live_.end()) return;  // the estimator rejected it (kUnknownFactor)
    const auto [robot, index] = it->second;
    if (index != kNoFactor) robots_[robot].factors[index] = nullptr;
    // A retracted prior keeps its value as the vertex guess: harmless for a dataset.
    live_.erase(it);
    ++result_->removed;
  }

  void AddMeasurement(const server::QueryRequest&) {}  // never journaled
  // g2o has no cameras: counted in the notes (the messages are in the LCM log).
  void AddMeasurement(const server::CameraInfo&) { Skip("camera_info_t messages"); }
  void AddMeasurement(const server::FrameObservations&) { Skip("frame_observations_t messages"); }
  // A neighbouring map shard's summary is no measurement of the robots.
  void AddMeasurement(const server::ShardSummaryMessage&) { Skip("shard_summary_t messages"); }

  // Vertex values: priors first, then breadth-first along the pose-pose edges, then the lowest
  // unknown pose at the identity (a new component), landmarks from their first observation.
  core::Status Initialise(const std::string& robot, const RobotGraph& g, core::Dataset* data) {
    std::map<std::uint64_t, core::Variable> value(g.priors.begin(), g.priors.end());
    std::map<std::uint64_t, std::vector<const core::Factor*>> edges;
    for (const core::FactorPtr& f : data->graph.factors()) {
      if (core::KeySymbol(f->keys()[1]) != 'x') continue;
      edges[core::KeyIndex(f->keys()[0])].push_back(f.get());
      edges[core::KeyIndex(f->keys()[1])].push_back(f.get());
    }
    std::deque<std::uint64_t> queue;
    for (const auto& [i, v] : value) queue.push_back(i);
    int components = 0;
    for (auto next = g.poses.begin();;) {
      while (!queue.empty()) {
        const std::uint64_t i = queue.front();
        queue.pop_front();
        for (const core::Factor* f : edges[i]) {
          const std::uint64_t a = core::KeyIndex(f->keys()[0]), b = core::KeyIndex(f->keys()[1]);
          const std::uint64_t other = a == i ? b : a;
          if (value.count(other)) continue;
          const std::optional<core::Variable> predicted = f->Predict(a == i ? 0 : 1, value[i]);
          SLAMD_CHECK(predicted) << f->Name() << " between poses predicts no pose";
          value[other] = *predicted;
          queue.push_back(other);
        }
      }
      while (next != g.poses.end() && value.count(*next)) ++next;
      if (next == g.poses.end()) break;
      value[*next] = data->is_3d ? core::Variable(core::Pose3()) : core::Variable(core::Pose2());
      queue.push_back(*next);
      ++components;
    }
    if (components > (g.priors.empty() ? 1 : 0)) {
      result_->notes.push_back("robot '" + robot + "': " + std::to_string(components) +
                               " pose components without a prior started at the identity");
    }
    for (const auto& [i, v] : value) {
      data->poses.push_back(Pose(i));
      SLAMD_RETURN_IF_ERROR(data->initial.Insert(Pose(i), v));
    }
    for (const auto& [i, v] : g.priors) data->fixed.push_back(Pose(i));
    for (const core::FactorPtr& f : data->graph.factors()) {
      const core::Key l = f->keys()[1];
      if (core::KeySymbol(l) != 'l' || data->initial.Contains(l)) continue;
      const std::optional<core::Variable> point =
          f->Predict(0, value[core::KeyIndex(f->keys()[0])]);
      SLAMD_CHECK(point) << f->Name() << " on a landmark predicts no point";
      SLAMD_RETURN_IF_ERROR(data->initial.Insert(l, *point));
    }
    for (std::uint64_t j : g.landmarks) data->landmarks.push_back(Landmark(j));
    return core::Status();
  }

  static constexpr std::size_t kNoFactor = static_cast<std::size_t>(-1);
  JournalExportResult* result_;
  std::map<std::string, RobotGraph> robots_;
  std::map<MeasurementId, std::pair<std::string, std::size_t>> live_;
  std::map<std::string, std::int64_t> skipped_;
  std::int64_t bearing_range_ = 0;  // bearing-range observations converted
};

}  // namespace

core::Result<JournalInspection> InspectJournal(const std::string& path, bool salvage) {
  JournalInspection out;
  const core::Status s =
      ReadRecords(path, salvage, &out,
                  [&](const journal::JournalRecord& r, std::int64_t offset, std::int64_t size) {
                    JournalRecordInfo info{.offset = offset, .size = size, .kind = RecordKind(r)};
                    if (r.has_message()) {
                      const journal::InboundMessage& m = r.message();
                      info.sequence = m.sequence();
                      info.type = m.message_type();
                      info.channel = m.channel();
                      core::Result<Inbound> in =
                          server::DecodeInbound(m.message_type(), Bytes(m.lcm_payload()));
                      if (in.ok()) {
                        info.robot = server::MessageRobot(in.value());
                      } else {
                        info.detail = in.status().message();
                      }
                      ++out.messages;
                      ++out.messages_by_type[m.message_type()];
                    } else if (r.has_boundary()) {
                      info.sequence = r.boundary().update_sequence();
                      info.detail = "last=" + std::to_string(r.boundary().last_message_sequence()) +
                                    " count=" + std::to_string(r.boundary().message_count());
                      ++out.boundaries;
                    } else if (r.has_refinement()) {
                      info.detail = "rounds=" + std::to_string(r.refinement().rounds());
                      ++out.refinements;
                    } else if (r.has_rebuild_swap()) {
                      info.sequence = r.rebuild_swap().update_sequence();
                      info.detail = "catch_up_rounds=";
                      for (int n : r.rebuild_swap().catch_up_rounds()) {
                        if (info.detail.back() != '=') info.detail += ',';
                        info.detail += std::to_string(n);
                      }
                      ++out.rebuild_swaps;
                    } else if (r.has_removal()) {
                      info.sequence = r.removal().update_sequence();
                      info.detail = "variables=" + std::to_string(r.removal().keys_size());
                    }
                    out.records.push_back(std::move(info));
                  });
  if (!s.ok()) return s;
  return out;
}

std::string FormatInspection(const JournalInspection& in) {
  std::ostringstream os;
  char line[512];
  std::snprintf(line, sizeof(line), "%12s  %-10s  %10s  %-24s  %-16s  %8s  %s\n", "offset", "kind",
                "sequence", "type", "robot", "size", "detail");
  os << line;
  for (const JournalRecordInfo& r : in.records) {
    std::snprintf(line, sizeof(line), "%12lld  %-10s  %10lld  %-24s  %-16s  %8lld  %s\n",
                  static_cast<long long>(r.offset), r.kind.c_str(),
                  static_cast<long long>(r.sequence), r.type.c_str(), r.robot.c_str(),
                  static_cast<long long>(r.size), r.detail.c_str());
    os << line;
  }
  os << "records: " << in.records.size() << " (messages " << in.messages << ", boundaries "
     << in.boundaries << ", refinements " << in.refinements << ", rebuild swaps "
     << in.rebuild_swaps << ")\n";
  if (!in.messages_by_type.empty()) {
    os << "messages by type:";
    for (const auto& [type, n] : in.messages_by_type) os << ' ' << type << '=' << n;
    os << '\n';
  }
  os << "journal: offsets " << in.first_offset << ".." << in.file_size << " in " << in.segments
     << " segment(s), " << in.disk_bytes << " bytes on disk; valid records end at "
     << in.valid_end_offset << '\n';
  if (in.end == "torn tail") {
    os << "end: torn tail at offset " << in.torn_tail_offset << " (" << in.end_reason
       << "): slamd truncates it at the next start\n";
  } else if (in.end == "corruption") {
    os << "end: CORRUPTION: " << in.corruption << " (slamd refuses to start without --salvage)\n";
  } else {
    os << "end: clean\n";
  }
  for (const std::string& s : in.skipped) os << "skipped (salvage): " << s << '\n';
  return os.str();
}

std::string InspectionJson(const JournalInspection& in) {
  std::string records = "[";
  for (size_t i = 0; i < in.records.size(); ++i) {
    const JournalRecordInfo& r = in.records[i];
    JsonWriter w;
    w.Add("offset", static_cast<long long>(r.offset))
        .Add("kind", r.kind)
        .Add("sequence", static_cast<long long>(r.sequence))
        .Add("type", r.type)
        .Add("channel", r.channel)
        .Add("robot", r.robot)
        .Add("size", static_cast<long long>(r.size))
        .Add("detail", r.detail);
    records += (i ? ", " : "") + w.str();
  }
  records += "]";
  JsonWriter by_type;
  for (const auto& [type, n] : in.messages_by_type) by_type.Add(type, static_cast<long long>(n));
  std::string skipped = "[";
  for (size_t i = 0; i < in.skipped.size(); ++i) {
    skipped += (i ? ", " : "") + JsonQuote(in.skipped[i]);
  }
  skipped += "]";
  JsonWriter w;
  w.Add("messages", static_cast<long long>(in.messages))
      .Add("boundaries", static_cast<long long>(in.boundaries))
      .Add("refinements", static_cast<long long>(in.refinements))
      .Add("rebuild_swaps", static_cast<long long>(in.rebuild_swaps))
      .Add("messages_by_type", by_type)
      .Add("file_size", static_cast<long long>(in.file_size))
      .Add("first_offset", static_cast<long long>(in.first_offset))
      .Add("disk_bytes", static_cast<long long>(in.disk_bytes))
      .Add("segments", in.segments)
      .Add("valid_end_offset", static_cast<long long>(in.valid_end_offset))
      .Add("end", in.end)
      .Add("torn_tail_offset", static_cast<long long>(in.torn_tail_offset))
      .Add("end_reason", in.end_reason)
      .Add("corruption", in.corruption)
      .Add("skipped_bytes", static_cast<long long>(in.skipped_bytes));
  // JsonWriter has no arrays: splice them in before the closing brace.
  std::string text = w.str();
  text.pop_back();
  return text + ", \"skipped\": " + skipped + ", \"records\": " + records + "}";
}

core::Result<JournalExportResult> ExportJournal(const std::string& journal_path,
                                                const std::string& out_dir,
                                                const JournalExportOptions& options) {
  JournalExportResult result;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) {
    return core::Status(core::StatusCode::kIoError,
                        "cannot create '" + out_dir + "': " + ec.message());
  }
  std::unique_ptr<lcm::LogFile> log;
  if (options.lcm_log) {
    result.lcm_log = out_dir + "/journal.lcmlog";
    log = std::make_unique<lcm::LogFile>(result.lcm_log, "w");
    if (!log->good()) {
      return core::Status(core::StatusCode::kIoError,
                          "cannot write the LCM log '" + result.lcm_log + "'");
    }
  }
  Exporter exporter(&result);
  JournalInspection end;
  bool write_failed = false;
  std::int64_t undecodable = 0;
  const core::Status s = ReadRecords(
      journal_path, options.salvage, &end,
      [&](const journal::JournalRecord& r, std::int64_t, std::int64_t) {
        if (!r.has_message()) return;
        const journal::InboundMessage& m = r.message();
        ++result.messages;
        if (log) {
          lcm::LogEvent event;
          event.eventnum = result.messages - 1;
          event.timestamp = m.received_wall_us();
          event.channel = m.channel();
          event.datalen = static_cast<std::int32_t>(m.lcm_payload().size());
          event.data = const_cast<char*>(m.lcm_payload().data());
          if (log->writeEvent(&event) != 0) write_failed = true;
        }
        if (!options.g2o) return;
        core::Result<Inbound> in = server::DecodeInbound(m.message_type(), Bytes(m.lcm_payload()));
        if (!in.ok()) {
          ++undecodable;
          return;
        }
        exporter.Add(in.value());
      });
  if (!s.ok()) return s;
  if (end.end == "corruption") {
    return core::Status(core::StatusCode::kDataLoss,
                        end.corruption + " (use --salvage to skip the damaged region)");
  }
  log.reset();  // closes (flushes) the log
  if (write_failed) {
    return core::Status(core::StatusCode::kIoError, "cannot write '" + result.lcm_log + "'");
  }
  if (options.g2o) SLAMD_RETURN_IF_ERROR(exporter.Write(out_dir));
  if (exporter.bearing_range() > 0) {
    result.notes.push_back(std::to_string(exporter.bearing_range()) +
                           " bearing-range observations written as EDGE_SE2_XY (first-order "
                           "covariance)");
  }
  if (undecodable > 0) {
    result.notes.push_back(std::to_string(undecodable) + " journaled messages did not decode");
  }
  if (end.end == "torn tail") {
    result.notes.push_back("torn tail at offset " + std::to_string(end.torn_tail_offset) + " (" +
                           end.end_reason + "): the records before it were exported");
  }
  if (end.skipped_bytes > 0) {
    result.notes.push_back("salvage skipped " + std::to_string(end.skipped_bytes) + " bytes");
  }
  return result;
}

}  // namespace slamd::clients
