// The files, number formatting, SourceLine, TokenStream, the quaternion and noise helpers and the
// field helpers of reader_internal.h.
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "core/base/key.h"
#include "core/io/reader_internal.h"

namespace slamd::core::internal {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Long lines are cut in messages: the point is to find the line, not to print it.
std::string Quoted(std::string_view text) {
  constexpr std::size_t kMaxShown = 160;
  std::string out = "'";
  out.append(text.substr(0, kMaxShown));
  if (text.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

std::string ToString(const FieldName& name) {
  std::string out(name.field);
  if (name.index >= 0) {
    out.append(" of ").append(name.record).append(" ").append(std::to_string(name.index));
  }
  return out;
}

// A finite double (a leading '+' allowed; overflow is not finite): false when the whole field
// is not one.
bool ParseFiniteNumber(std::string_view field, double* out) {
  // from_chars rejects a leading '+', which some writers emit.
  if (field.size() > 1 && field[0] == '+' && field[1] != '-') field.remove_prefix(1);
  const char* end = field.data() + field.size();
  const auto [ptr, ec] = std::from_chars(field.data(), end, *out);
  bool ok = ec == std::errc() && ptr == end;
  if (ec == std::errc::result_out_of_range && ptr == end) {
    // Overflow or underflow: strtod tells which (underflow to a tiny value or 0 is fine).
    *out = std::strtod(std::string(field).c_str(), nullptr);
    ok = true;
  }
  return ok && std::isfinite(*out);
}

// An unsigned integer in [0, max]: false when the whole field is not one.
bool ParseInteger(std::string_view field, std::uint64_t max, std::uint64_t* out) {
  const char* end = field.data() + field.size();
  const auto [ptr, ec] = std::from_chars(field.data(), end, *out);
  return ec == std::errc() && ptr == end && *out <= max;
}

}  // namespace

Status ProblemAt(const std::string& path, int line, std::string_view message) {
  return DataLoss(path + ":" + std::to_string(line) + ": " + std::string(message));
}

Result<std::string> ReadTextFile(const std::string& path, std::string_view what) {
  const std::string name = std::string(what) + " '" + path + "'";
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return NotFound(name + " not found");
  if (!std::filesystem::is_regular_file(path, ec)) {
    return IoError(name + " is not a regular file");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) return IoError("cannot open " + name);
  std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  if (file.bad()) return IoError("reading " + name + " failed");
  return text;
}

Status WriteTextFile(const std::string& path, std::string_view text, std::string_view writer) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) return IoError(std::string(writer) + ": cannot open '" + path + "' for writing");
  file.write(text.data(), static_cast<std::streamsize>(text.size()));
  file.close();
  if (!file) return IoError(std::string(writer) + ": writing '" + path + "' failed");
  return Status::Ok();
}

void AppendNumber(double x, std::string* out) {
  char buf[32];
  const auto result = std::to_chars(buf, buf + sizeof(buf), x);
  out->append(buf, result.ptr);
}

void AppendNumbers(std::initializer_list<double> values, std::string* out) {
  for (const double x : values) {
    out->push_back(' ');
    AppendNumber(x, out);
  }
}

SourceLine::SourceLine(const std::string& path, int number, std::string_view text)
    : path_(&path), number_(number), text_(text) {
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && IsBlank(text[i])) ++i;
    const std::size_t start = i;
    while (i < text.size() && !IsBlank(text[i])) ++i;
    if (i > start) fields_.push_back(text.substr(start, i - start));
  }
  // Messages quote the line without its trailing blanks (and '\r').
  while (!text_.empty() && IsBlank(text_.back())) text_.remove_suffix(1);
}

Status SourceLine::Problem(std::string_view message) const {
  return ProblemAt(*path_, number_, message);
}

Status SourceLine::Error(std::string_view expected) const {
  return Problem("expected " + std::string(expected) + ", got " + Quoted(text_));
}

Status SourceLine::ExpectValues(int count, std::string_view layout) const {
  if (num_values() == count) return Status::Ok();
  return Error(std::string(layout) + " (" + std::to_string(count) + " values after the tag, not " +
               std::to_string(num_values()) + ")");
}

Status SourceLine::ExpectValues(int count_a, int count_b, std::string_view layout) const {
  if (num_values() == count_a || num_values() == count_b) return Status::Ok();
  return Error(std::string(layout) + " (" + std::to_string(count_a) + " or " +
               std::to_string(count_b) + " values after the tag, not " +
               std::to_string(num_values()) + ")");
}

Status SourceLine::Number(int i, double* out) const {
  SLAMD_CHECK(i >= 0 && i < num_values()) << "reader bug: value " << i << " of " << num_values();
  if (ParseFiniteNumber(fields_[i + 1], out)) return Status::Ok();
  return Problem("expected a finite number as value " + std::to_string(i + 1) + " of " +
                 std::string(tag()) + ", got " + Quoted(fields_[i + 1]));
}

Status SourceLine::Id(int i, std::uint64_t* out) const {
  SLAMD_CHECK(i >= 0 && i < num_values()) << "reader bug: value " << i << " of " << num_values();
  const std::string_view field = fields_[i + 1];
  if (ParseInteger(field, kMaxKeyIndex, out)) return Status::Ok();
  return Problem("expected an id (an integer in 0..2^48-1) as value " + std::to_string(i + 1) +
                 " of " + std::string(tag()) + ", got " + Quoted(field));
}

Status SourceLine::Numbers(int first, int count, double* out) const {
  for (int k = 0; k < count; ++k) SLAMD_RETURN_IF_ERROR(Number(first + k, out + k));
  return Status::Ok();
}

Status SourceLine::FieldNumber(int k, const FieldName& name, double* out) const {
  SLAMD_CHECK(k >= 0 && k < num_fields()) << "reader bug: field " << k << " of " << num_fields();
  if (ParseFiniteNumber(fields_[k], out)) return Status::Ok();
  return Problem("expected " + ToString(name) + " (a finite number), got " + Quoted(fields_[k]));
}

Status SourceLine::FieldInteger(int k, const FieldName& name, std::uint64_t max,
                                std::uint64_t* out) const {
  SLAMD_CHECK(k >= 0 && k < num_fields()) << "reader bug: field " << k << " of " << num_fields();
  if (ParseInteger(fields_[k], max, out)) return Status::Ok();
  return Problem("expected " + ToString(name) + " (an integer in [0, " + std::to_string(max) +
                 "]), got " + Quoted(fields_[k]));
}

std::vector<SourceLine> SplitLines(const std::string& path, std::string_view text) {
  std::vector<SourceLine> lines;
  int number = 0;
  for (std::size_t start = 0; start < text.size();) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    lines.emplace_back(path, ++number, text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

TokenStream::TokenStream(const std::string& path, std::string_view text)
    : path_(&path), text_(text) {}

bool TokenStream::Next(std::string_view* token) {
  while (pos_ < text_.size() && (IsBlank(text_[pos_]) || text_[pos_] == '\n')) {
    if (text_[pos_] == '\n') ++line_;
    ++pos_;
  }
  if (pos_ == text_.size()) return false;
  const std::size_t start = pos_;
  while (pos_ < text_.size() && !IsBlank(text_[pos_]) && text_[pos_] != '\n') ++pos_;
  *token = text_.substr(start, pos_ - start);
  token_line_ = line_;
  return true;
}

Status TokenStream::Expected(const FieldName& name, std::string_view kind, bool at_end,
                             std::string_view token) const {
  std::string message = "expected " + ToString(name) + " (" + std::string(kind) + "), got ";
  message += at_end ? std::string("the end of the file") : Quoted(token);
  return ProblemAt(*path_, token_line_, message);
}

Status TokenStream::Number(const FieldName& name, double* out) {
  std::string_view token;
  const bool found = Next(&token);
  if (found && ParseFiniteNumber(token, out)) return Status::Ok();
  return Expected(name, "a finite number", !found, token);
}

Status TokenStream::Index(const FieldName& name, std::uint64_t limit, std::uint64_t* out) {
  std::string_view token;
  const bool found = Next(&token);
  if (found && limit > 0 && ParseInteger(token, limit - 1, out)) return Status::Ok();
  return Expected(name, "an integer in [0, " + std::to_string(limit) + ")", !found, token);
}

Status TokenStream::End(std::string_view after) {
  std::string_view token;
  if (!Next(&token)) return Status::Ok();
  return ProblemAt(
      *path_, token_line_,
      "expected the end of the file after " + std::string(after) + ", got " + Quoted(token));
}

Status RotationFromQuaternion(const SourceLine& line, std::string_view layout, double w, double x,
                              double y, double z, Rot3* R) {
  const double norm = Eigen::Vector4d(w, x, y, z).norm();
  if (!(norm > 1e-6) || !std::isfinite(norm)) {
    return line.Error("a quaternion " + std::string(layout) + " of finite, non-zero norm");
  }
  *R = Rot3::FromQuaternion(w, x, y, z);
  return Status::Ok();
}

Eigen::MatrixXd SymmetricFromUpperRowMajor(const double* values, int n) {
  Eigen::MatrixXd m(n, n);
  for (int r = 0, k = 0; r < n; ++r) {
    for (int c = r; c < n; ++c, ++k) m(r, c) = m(c, r) = values[k];
  }
  return m;
}

Eigen::MatrixXd UpperTriangularFromRowMajor(const double* values, int n) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
  for (int r = 0, k = 0; r < n; ++r) {
    for (int c = r; c < n; ++c, ++k) m(r, c) = values[k];
  }
  return m;
}

Result<NoiseModel> NoiseFromInformation(const SourceLine& line,
                                        const Eigen::MatrixXd& information) {
  Result<NoiseModel> noise = NoiseModel::FromInformation(information);
  if (!noise.ok()) return line.Problem("invalid noise: " + noise.status().message());
  return noise;
}

Result<NoiseModel> NoiseFromSqrtInformation(const SourceLine& line,
                                            const Eigen::MatrixXd& sqrt_info) {
  Result<NoiseModel> noise = NoiseModel::FromSqrtInformation(sqrt_info);
  if (!noise.ok()) return line.Problem("invalid noise: " + noise.status().message());
  return noise;
}

Result<NoiseModel> NoiseFromCovariance(const SourceLine& line, const Eigen::MatrixXd& covariance) {
  Result<NoiseModel> noise = NoiseModel::FromCovariance(covariance);
  if (!noise.ok()) return line.Problem("invalid noise: " + noise.status().message());
  return noise;
}

Status ReadVertexFields(const SourceLine& line, std::string_view layout, bool is_3d, int count,
                        DatasetBuilder* builder, std::uint64_t* id, double* numbers) {
  SLAMD_RETURN_IF_ERROR(line.ExpectValues(1 + count, layout));
  SLAMD_RETURN_IF_ERROR(builder->SetDimension(line, is_3d));
  SLAMD_RETURN_IF_ERROR(line.Id(0, id));
  return line.Numbers(1, count, numbers);
}

Status ReadEdgeFields(const SourceLine& line, std::string_view layout, bool is_3d, int count,
                      DatasetBuilder* builder, std::uint64_t* i, std::uint64_t* j,
                      double* numbers) {
  SLAMD_RETURN_IF_ERROR(line.ExpectValues(2 + count, layout));
  return ParseEdgeFields(line, is_3d, count, builder, i, j, numbers);
}

Status ParseEdgeFields(const SourceLine& line, bool is_3d, int count, DatasetBuilder* builder,
                       std::uint64_t* i, std::uint64_t* j, double* numbers) {
  SLAMD_CHECK(count == line.num_values() - 2)
      << "reader bug: " << count << " numbers after two ids, but " << line.num_values()
      << " values";
  SLAMD_RETURN_IF_ERROR(builder->SetDimension(line, is_3d));
  SLAMD_RETURN_IF_ERROR(line.Id(0, i));
  SLAMD_RETURN_IF_ERROR(line.Id(1, j));
  return line.Numbers(2, count, numbers);
}

Status ReadPose2Vertex(const SourceLine& line, std::string_view layout, DatasetBuilder* builder) {
  std::uint64_t id;
  double v[3];
  SLAMD_RETURN_IF_ERROR(ReadVertexFields(line, layout, /*is_3d=*/false, 3, builder, &id, v));
  return builder->AddPoseVertex(line, id, Pose2(v[0], v[1], v[2]));
}

}  // namespace slamd::core::internal
