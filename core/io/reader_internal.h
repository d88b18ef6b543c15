// Internal to core/io: what the format readers and writers share. Not part of the public API.
//
//  * Files: ReadTextFile / WriteTextFile (whole files, kNotFound / kIoError statuses), and
//    AppendNumber, the shortest text that reads back to the same double.
//  * SourceLine: one line split into fields, with helpers that parse the numeric fields and turn
//    every problem into a "FILE:LINE: expected ..., got '...'" status; SplitLines cuts a text
//    into them.
//  * TokenStream: the same for formats whose numbers may spread over lines arbitrarily (BAL).
//  * RotationFromQuaternion: a quaternion field group as a rotation (g2o, COLMAP).
//  * Noise helpers: symmetric matrices from the upper triangles the formats store.
//  * DatasetBuilder: collects vertices and measurements from any reader, then builds the
//    Dataset (keys, factor graph, initial guess by composition along the edges).
//  * Field helpers: the "<id> numbers" / "<i> <j> numbers" head every vertex and edge line shares.
//  * The per-format line readers (g2o.cc, toro.cc, isam.cc).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/base/status.h"
#include "core/factors/noise_model.h"
#include "core/io/dataset.h"
#include "core/variables/variable.h"

namespace slamd::core::internal {

// The whole file at `path`. kNotFound "<what> '<path>' not found" when it does not exist,
// kIoError when it is not a regular file or cannot be read.
Result<std::string> ReadTextFile(const std::string& path, std::string_view what);
// Replaces the file at `path` with `text`; kIoError "<writer>: cannot open ... / writing ...
// failed" otherwise. Writers format everything first, so invalid input leaves no partial file.
Status WriteTextFile(const std::string& path, std::string_view text, std::string_view writer);
// Appends `x` in the shortest form that reads back to the same double (std::to_chars).
void AppendNumber(double x, std::string* out);
// Appends each of `values` as " <x>", in that form.
void AppendNumbers(std::initializer_list<double> values, std::string* out);

// "FILE:LINE: <message>" as kDataLoss.
Status ProblemAt(const std::string& path, int line, std::string_view message);

// What a field is, for messages: "<field>", or "<field> of <record> <index>" when index >= 0.
// Put into words only on error, so that naming every field of a large file costs nothing.
struct FieldName {
  std::string_view field;
  std::string_view record = {};
  std::int64_t index = -1;
};

// One line of a text file, split into fields at blanks (spaces, tabs, '\r').
class SourceLine {
 public:
  SourceLine(const std::string& path, int number, std::string_view text);

  const std::string& path() const { return *path_; }
  int number() const { return number_; }
  std::string_view text() const { return text_; }
  // Not blank and not a comment (first field starting with '#').
  bool IsRecord() const { return !fields_.empty() && fields_[0][0] != '#'; }
  int num_fields() const { return static_cast<int>(fields_.size()); }
  std::string_view field(int k) const { return fields_[k]; }
  // The first field (the record type).
  std::string_view tag() const { return fields_.empty() ? std::string_view() : fields_[0]; }
  // Fields after the tag.
  int num_values() const { return static_cast<int>(fields_.size()) - 1; }

  // "FILE:LINE: expected <expected>, got '<text of the line>'" as kDataLoss.
  Status Error(std::string_view expected) const;
  // "FILE:LINE: <message>" as kDataLoss (for problems that are not about the syntax).
  Status Problem(std::string_view message) const;

  // Ok when num_values() is one of the allowed counts; otherwise an error such as
  // "expected EDGE_SE2 i j dx dy dθ I11 I12 I13 I22 I23 I33 (11 numbers), got ...".
  Status ExpectValues(int count, std::string_view layout) const;
  Status ExpectValues(int count_a, int count_b, std::string_view layout) const;

  // Field i after the tag (0-based) as a finite double / an id in [0, 2^48-1].
  Status Number(int i, double* out) const;
  Status Id(int i, std::uint64_t* out) const;
  // Fields first .. first+count-1 as finite doubles.
  Status Numbers(int first, int count, double* out) const;

  // Field k, counting the tag as field 0, for formats without a tag (COLMAP): a finite double /
  // an integer in [0, max]; otherwise "expected <name> (a finite number), got '<field>'" /
  // "expected <name> (an integer in [0, <max>]), got '<field>'".
  Status FieldNumber(int k, const FieldName& name, double* out) const;
  Status FieldInteger(int k, const FieldName& name, std::uint64_t max, std::uint64_t* out) const;

 private:
  const std::string* path_;
  int number_;
  std::string_view text_;
  std::vector<std::string_view> fields_;
};

// Every line of `text` (blank lines and comments included), numbered from 1; the lines refer to
// `path` and `text`, which must outlive them. A final line without '\n' counts; nothing after a
// final '\n' does.
std::vector<SourceLine> SplitLines(const std::string& path, std::string_view text);

// The blank-separated tokens of a text, one after the other across lines (BAL lets its numbers
// spread over lines arbitrarily), each parsed with the line it is on, so that problems are still
// reported as "FILE:LINE: expected <name> (...), got '<token>'" or "..., got the end of the
// file".
class TokenStream {
 public:
  // `path` and `text` must outlive the stream.
  TokenStream(const std::string& path, std::string_view text);

  // The next token as a finite double / an integer in [0, limit) (note: exclusive, so that a count
  // of 0 admits nothing).
  Status Number(const FieldName& name, double* out);
  Status Index(const FieldName& name, std::uint64_t limit, std::uint64_t* out);
  // Ok when no token is left; otherwise "FILE:LINE: expected the end of the file after <after>,
  // got '<token>'".
  Status End(std::string_view after);

 private:
  // The next token (its line in token_line_); false at the end of the text.
  bool Next(std::string_view* token);
  // "FILE:LINE: expected <name> (<kind>), got '<token>'" or "..., got the end of the file", at
  // the line of the token (of the last token at the end of the file).
  Status Expected(const FieldName& name, std::string_view kind, bool at_end,
                  std::string_view token) const;

  const std::string* path_;
  std::string_view text_;
  std::size_t pos_ = 0;  // where the next token search starts
  int line_ = 1;         // the line at pos_
  int token_line_ = 1;   // the line of the last token returned
};

// The rotation of quaternion (w, x, y, z), normalised; "FILE:LINE: expected a quaternion
// <layout> of finite, non-zero norm, got '<line>'" when its norm is not.
Status RotationFromQuaternion(const SourceLine& line, std::string_view layout, double w, double x,
                              double y, double z, Rot3* R);

// The symmetric n x n matrix whose upper triangle, row by row, is values[0..n(n+1)/2).
Eigen::MatrixXd SymmetricFromUpperRowMajor(const double* values, int n);
// The upper-triangular n x n matrix whose upper triangle, row by row, is values[...].
Eigen::MatrixXd UpperTriangularFromRowMajor(const double* values, int n);
// NoiseModel from an information / sqrt-information / covariance matrix; a failure is reported
// against `line` ("FILE:LINE: invalid noise: <NoiseModel message>").
Result<NoiseModel> NoiseFromInformation(const SourceLine& line, const Eigen::MatrixXd& information);
Result<NoiseModel> NoiseFromSqrtInformation(const SourceLine& line,
                                            const Eigen::MatrixXd& sqrt_info);
Result<NoiseModel> NoiseFromCovariance(const SourceLine& line, const Eigen::MatrixXd& covariance);

// Collects what the readers find and builds the Dataset. Every Add* validates before it stores.
class DatasetBuilder {
 public:
  DatasetBuilder(std::string path, DatasetFormat format);

  // Records the dimension (2D / 3D) of a line; the first line decides, and a later line of the
  // other dimension is an error. Every Add* must be preceded by it (checked).
  Status SetDimension(const SourceLine& line, bool is_3d);

  Status AddPoseVertex(const SourceLine& line, std::uint64_t id, const Variable& pose);
  Status AddLandmarkVertex(const SourceLine& line, std::uint64_t id, const Variable& point);
  // A pose-pose measurement: x_j = x_i ∘ measured (Pose2 or Pose3). `equivalence` marks TORO
  // EQUIV (counted apart from the edges).
  Status AddPoseEdge(const SourceLine& line, std::uint64_t i, std::uint64_t j,
                     const Variable& measured, NoiseModel noise, bool equivalence = false);
  // Landmark `lm` seen from pose `pose` at `measured` (Point2 or Point3) in the pose's frame.
  Status AddLandmarkObservation(const SourceLine& line, std::uint64_t pose, std::uint64_t lm,
                                const Variable& measured, NoiseModel noise);
  // g2o FIX: the pose must appear somewhere in the file (checked by Finish).
  void AddFixed(const SourceLine& line, std::uint64_t id) { fixed_.push_back({id, line.number()}); }

  // Builds keys, the graph and the initial guess (see dataset.h). Consumes the builder.
  Result<Dataset> Finish(const ReadOptions& options) &&;

 private:
  struct PoseEdge {
    std::uint64_t i, j;
    Variable measured;
  };
  struct Observation {
    std::uint64_t pose, landmark;
    Variable measured;
  };
  // Step 1 of the initial guess (dataset.h): poses from vertices and composition.
  Status InitialPoses(const ReadOptions& options, std::map<std::uint64_t, Variable>* poses) const;
  // Step 2: landmarks from vertices or their first observation.
  void InitialLandmarks(const ReadOptions& options, const std::map<std::uint64_t, Variable>& poses,
                        std::map<std::uint64_t, Variable>* landmarks) const;

  Dataset dataset_;
  bool dimension_set_ = false;
  std::map<std::uint64_t, Variable> pose_vertices_;
  std::map<std::uint64_t, Variable> landmark_vertices_;
  std::vector<std::uint64_t> pose_ids_;      // every pose id seen (vertex or edge); Finish sorts
  std::vector<std::uint64_t> landmark_ids_;  // every landmark id seen; Finish sorts
  std::vector<PoseEdge> edges_;              // pose-pose measurements in file order
  std::vector<Observation> observations_;    // landmark measurements in file order
  struct Fixed {
    std::uint64_t id;
    int line;
  };
  std::vector<Fixed> fixed_;
};

// The values after the tag of a vertex line, "<id> x_1 .. x_count", and of an edge line,
// "<i> <j> x_1 .. x_count". Every reader handles them in the same order, so the first problem of a
// line is reported the same way in every format:
//   1. the count (ExpectValues(1 + count or 2 + count, layout): "expected <layout> (...)"),
//   2. the dimension of the line (builder->SetDimension(line, is_3d)),
//   3. the ids, then the numbers, left to right.
// `numbers` must hold `count` doubles (it may be null when count is 0).
Status ReadVertexFields(const SourceLine& line, std::string_view layout, bool is_3d, int count,
                        DatasetBuilder* builder, std::uint64_t* id, double* numbers);
Status ReadEdgeFields(const SourceLine& line, std::string_view layout, bool is_3d, int count,
                      DatasetBuilder* builder, std::uint64_t* i, std::uint64_t* j, double* numbers);
// Steps 2 and 3 of ReadEdgeFields, for readers with their own count check (iSAM EDGE3, whose
// count is one of two). Checks (a reader bug otherwise) that count == line.num_values() - 2.
Status ParseEdgeFields(const SourceLine& line, bool is_3d, int count, DatasetBuilder* builder,
                       std::uint64_t* i, std::uint64_t* j, double* numbers);
// "<tag> id x y θ": a Pose2 vertex (g2o VERTEX_SE2, TORO VERTEX2); `layout` as above.
Status ReadPose2Vertex(const SourceLine& line, std::string_view layout, DatasetBuilder* builder);

// Per-format line readers: handle one line of their format (unknown tags are errors).
Status ReadG2oLine(const SourceLine& line, DatasetBuilder* builder);
Status ReadToroLine(const SourceLine& line, DatasetBuilder* builder);
Status ReadIsamLine(const SourceLine& line, ReadOptions::IsamNoise noise, DatasetBuilder* builder);

}  // namespace slamd::core::internal
