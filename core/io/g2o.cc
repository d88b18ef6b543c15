// The g2o format: reading one line (ReadG2oLine) and writing a whole Dataset (WriteG2o).
// Layouts and conventions: dataset.h.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/factors/factor.h"
#include "core/io/dataset.h"
#include "core/io/reader_internal.h"

namespace slamd::core {
namespace internal {
namespace {

// Rotation from a g2o quaternion, stored x y z w (w LAST).
Status ReadQuaternion(const SourceLine& line, const double* xyzw, Rot3* R) {
  return RotationFromQuaternion(line, "qx qy qz qw", xyzw[3], xyzw[0], xyzw[1], xyzw[2], R);
}

Status ReadEdgeSe2(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t i, j;
  double v[9];
  SLAMD_RETURN_IF_ERROR(ReadEdgeFields(line, "EDGE_SE2 i j dx dy dθ I11 I12 I13 I22 I23 I33",
                                       /*is_3d=*/false, 9, builder, &i, &j, v));
  Result<NoiseModel> noise = NoiseFromInformation(line, SymmetricFromUpperRowMajor(v + 3, 3));
  if (!noise.ok()) return noise.status();
  return builder->AddPoseEdge(line, i, j, Pose2(v[0], v[1], v[2]), std::move(noise).value());
}

Status ReadVertexXy(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t id;
  double v[2];
  SLAMD_RETURN_IF_ERROR(
      ReadVertexFields(line, "VERTEX_XY id x y", /*is_3d=*/false, 2, builder, &id, v));
  return builder->AddLandmarkVertex(line, id, Point2(v[0], v[1]));
}

Status ReadEdgeSe2Xy(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t i, j;
  double v[5];
  SLAMD_RETURN_IF_ERROR(ReadEdgeFields(line, "EDGE_SE2_XY i j dx dy I11 I12 I22", /*is_3d=*/false,
                                       5, builder, &i, &j, v));
  Result<NoiseModel> noise = NoiseFromInformation(line, SymmetricFromUpperRowMajor(v + 2, 2));
  if (!noise.ok()) return noise.status();
  return builder->AddLandmarkObservation(line, i, j, Point2(v[0], v[1]), std::move(noise).value());
}

Status ReadVertexSe3Quat(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t id;
  double v[7];
  SLAMD_RETURN_IF_ERROR(ReadVertexFields(line, "VERTEX_SE3:QUAT id x y z qx qy qz qw",
                                         /*is_3d=*/true, 7, builder, &id, v));
  Rot3 R;
  SLAMD_RETURN_IF_ERROR(ReadQuaternion(line, v + 3, &R));
  return builder->AddPoseVertex(line, id, Pose3(R, Point3(v[0], v[1], v[2])));
}

Status ReadEdgeSe3Quat(const SourceLine& line, DatasetBuilder* builder) {
  std::uint64_t i, j;
  double v[28];
  SLAMD_RETURN_IF_ERROR(
      ReadEdgeFields(line, "EDGE_SE3:QUAT i j dx dy dz qx qy qz qw + 21 information values",
                     /*is_3d=*/true, 28, builder, &i, &j, v));
  Rot3 R;
  SLAMD_RETURN_IF_ERROR(ReadQuaternion(line, v + 3, &R));
  // g2o's (t, R) information order is slamd's Pose3 tangent order: no block swap.
  Result<NoiseModel> noise = NoiseFromInformation(line, SymmetricFromUpperRowMajor(v + 7, 6));
  if (!noise.ok()) return noise.status();
  return builder->AddPoseEdge(line, i, j, Pose3(R, Point3(v[0], v[1], v[2])),
                              std::move(noise).value());
}

Status ReadFix(const SourceLine& line, DatasetBuilder* builder) {
  if (line.num_values() < 1) return line.Error("FIX id [id ...]");
  for (int k = 0; k < line.num_values(); ++k) {
    std::uint64_t id;
    SLAMD_RETURN_IF_ERROR(line.Id(k, &id));
    builder->AddFixed(line, id);
  }
  return Status::Ok();
}

}  // namespace

Status ReadG2oLine(const SourceLine& line, DatasetBuilder* builder) {
  const std::string_view tag = line.tag();
  if (tag == "VERTEX_SE2") return ReadPose2Vertex(line, "VERTEX_SE2 id x y θ", builder);
  if (tag == "EDGE_SE2") return ReadEdgeSe2(line, builder);
  if (tag == "VERTEX_XY") return ReadVertexXy(line, builder);
  if (tag == "EDGE_SE2_XY") return ReadEdgeSe2Xy(line, builder);
  if (tag == "VERTEX_SE3:QUAT") return ReadVertexSe3Quat(line, builder);
  if (tag == "EDGE_SE3:QUAT") return ReadEdgeSe3Quat(line, builder);
  if (tag == "FIX") return ReadFix(line, builder);
  return line.Problem(
      "expected a g2o tag (VERTEX_SE2, EDGE_SE2, VERTEX_XY, EDGE_SE2_XY, "
      "VERTEX_SE3:QUAT, EDGE_SE3:QUAT, FIX), got the unknown tag '" +
      std::string(tag) + "'");
}

}  // namespace internal

namespace {

// Appends the fields of one line, numbers in their shortest exact form.
class LineWriter {
 public:
  explicit LineWriter(std::string* out) : out_(out) {}
  LineWriter& Tag(const char* tag) {
    out_->append(tag);
    return *this;
  }
  LineWriter& Id(Key key) {
    out_->append(" ").append(std::to_string(KeyIndex(key)));
    return *this;
  }
  LineWriter& Num(double x) {
    internal::AppendNumbers({x}, out_);
    return *this;
  }
  LineWriter& UpperTriangle(const Eigen::MatrixXd& m) {
    for (int r = 0; r < m.rows(); ++r) {
      for (int c = r; c < m.cols(); ++c) Num(m(r, c));
    }
    return *this;
  }
  LineWriter& Quaternion(const Rot3& R) {  // x y z w
    const Eigen::Quaterniond q = R.ToQuaternion();
    return Num(q.x()).Num(q.y()).Num(q.z()).Num(q.w());
  }
  void End() { out_->append("\n"); }

 private:
  std::string* out_;
};

Status CheckKey(Key key, unsigned char symbol) {
  if (KeySymbol(key) == symbol && KeyRobot(key) == 0) return Status::Ok();
  return InvalidArgument("WriteG2o: key " + KeyToString(key) + " is not a '" +
                         std::string(1, static_cast<char>(symbol)) +
                         "' key without a robot id, so it has no g2o id");
}

// A value in g2o's layout: Pose2 x y θ, Pose3 x y z qx qy qz qw, Point2 x y (the kinds g2o has
// here; checked by the callers).
void WriteValue(const Variable& v, LineWriter* w) {
  if (const Pose2* p = std::get_if<Pose2>(&v)) {
    w->Num(p->x()).Num(p->y()).Num(p->theta());
  } else if (const Pose3* p = std::get_if<Pose3>(&v)) {
    const Point3& t = p->translation();
    w->Num(t.x()).Num(t.y()).Num(t.z()).Quaternion(p->rotation());
  } else {
    const Point2& q = std::get<Point2>(v);
    w->Num(q.x()).Num(q.y());
  }
}

Status WriteVertex(const Dataset& dataset, Key key, bool landmark, std::string* out) {
  SLAMD_RETURN_IF_ERROR(CheckKey(key, landmark ? 'l' : 'x'));
  const int slot = dataset.initial.SlotOf(key);
  if (slot < 0) {
    return InvalidArgument("WriteG2o: " + KeyToString(key) + " has no value in dataset.initial");
  }
  LineWriter w(out);
  const Variable& v = dataset.initial.VariableAt(slot);
  const bool is_point = std::holds_alternative<Point2>(v) || std::holds_alternative<Point3>(v);
  if (is_point != landmark) {
    return InvalidArgument(
        "WriteG2o: " + KeyToString(key) + " holds a " + VariableTypeName(TypeOf(v)) +
        ", expected a " +
        (landmark ? "point (it is in dataset.landmarks)" : "pose (it is in dataset.poses)"));
  }
  const char* tag = std::holds_alternative<Pose2>(v)    ? "VERTEX_SE2"
                    : std::holds_alternative<Pose3>(v)  ? "VERTEX_SE3:QUAT"
                    : std::holds_alternative<Point2>(v) ? "VERTEX_XY"
                                                        : nullptr;
  if (tag == nullptr) {
    return InvalidArgument("WriteG2o: " + KeyToString(key) + " is a " +
                           VariableTypeName(TypeOf(v)) + ", which has no g2o vertex here");
  }
  w.Tag(tag).Id(key);
  WriteValue(v, &w);
  w.End();
  return Status::Ok();
}

Status WriteFactor(const Factor& factor, std::size_t index, std::string* out) {
  const char* tag = factor.Formats().g2o;
  const std::optional<Variable> measured = factor.Measured();
  if (tag == nullptr || !measured) {
    return InvalidArgument("WriteG2o: factor " + std::to_string(index) + " (" + factor.Name() +
                           ") has no g2o form");
  }
  LineWriter w(out);
  w.Tag(tag);
  for (int k = 0; k < static_cast<int>(factor.keys().size()); ++k) {
    // Poses (kinds with rotation entries) are g2o's 'x' vertices, points its 'l' ones.
    const bool pose = std::ranges::count(EntryKinds(factor.KeyType(k)), EntryKind::kRotation) > 0;
    SLAMD_RETURN_IF_ERROR(CheckKey(factor.keys()[k], pose ? 'x' : 'l'));
    w.Id(factor.keys()[k]);
  }
  WriteValue(*measured, &w);
  w.UpperTriangle(factor.noise_model().Information()).End();
  return Status::Ok();
}

}  // namespace

Status WriteG2o(const Dataset& dataset, const std::string& path) {
  // Everything is formatted first, so that an unwritable dataset leaves no partial file.
  std::string out;
  for (const Key key : dataset.fixed) {
    SLAMD_RETURN_IF_ERROR(CheckKey(key, 'x'));
    LineWriter(&out).Tag("FIX").Id(key).End();
  }
  for (const Key key : dataset.poses) SLAMD_RETURN_IF_ERROR(WriteVertex(dataset, key, false, &out));
  for (const Key key : dataset.landmarks) {
    SLAMD_RETURN_IF_ERROR(WriteVertex(dataset, key, true, &out));
  }
  for (std::size_t i = 0; i < dataset.graph.size(); ++i) {
    SLAMD_RETURN_IF_ERROR(WriteFactor(*dataset.graph[i], i, &out));
  }
  return internal::WriteTextFile(path, out, "WriteG2o");
}

}  // namespace slamd::core
