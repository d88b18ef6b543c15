// ReadDataset: reads the file, detects its format and runs that format's line reader.
#include "core/io/dataset.h"

#include <string>
#include <vector>

#include "core/io/reader_internal.h"

namespace slamd::core {
namespace {

using internal::SourceLine;

bool IsG2oTag(std::string_view tag) {
  return tag == "VERTEX_SE2" || tag == "EDGE_SE2" || tag == "VERTEX_XY" || tag == "EDGE_SE2_XY" ||
         tag == "VERTEX_SE3:QUAT" || tag == "EDGE_SE3:QUAT" || tag == "FIX";
}

bool EndsWith(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

// The first decisive tag decides (dataset.h); EDGE2 alone is TORO only in a *.graph file.
Result<DatasetFormat> DetectFormat(const std::string& path, const std::vector<SourceLine>& lines) {
  const bool graph_file = EndsWith(path, ".graph");
  bool saw_edge2 = false;
  for (const SourceLine& line : lines) {
    const std::string_view tag = line.tag();
    if (IsG2oTag(tag)) return DatasetFormat::kG2o;
    if (tag == "VERTEX2" || tag == "EQUIV") return DatasetFormat::kToro;
    if (tag == "ODOMETRY" || tag == "LANDMARK") return DatasetFormat::kIsam;
    if (tag == "EDGE3" || tag == "VERTEX3") {
      return graph_file ? DatasetFormat::kToro : DatasetFormat::kIsam;
    }
    if (tag == "EDGE2") {
      if (graph_file) return DatasetFormat::kToro;
      saw_edge2 = true;
      continue;
    }
    return line.Problem("expected a g2o, TORO or iSAM tag, got the unknown tag '" +
                        std::string(tag) + "'");
  }
  if (saw_edge2) return DatasetFormat::kIsam;
  return DataLoss(path + ": expected vertex or edge lines, found none (empty file?)");
}

Status ReadLine(DatasetFormat format, const ReadOptions& options, const SourceLine& line,
                internal::DatasetBuilder* builder) {
  switch (format) {
    case DatasetFormat::kG2o:
      return internal::ReadG2oLine(line, builder);
    case DatasetFormat::kToro:
      return internal::ReadToroLine(line, builder);
    case DatasetFormat::kIsam:
      return internal::ReadIsamLine(line, options.isam_noise, builder);
    case DatasetFormat::kAuto:
      break;
  }
  SLAMD_CHECK(false) << "ReadLine needs a concrete format";
  return Status::Ok();
}

}  // namespace

const char* DatasetFormatName(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::kAuto:
      return "auto";
    case DatasetFormat::kG2o:
      return "g2o";
    case DatasetFormat::kToro:
      return "TORO";
    case DatasetFormat::kIsam:
      return "iSAM";
  }
  return "unknown";
}

Result<Dataset> ReadDataset(const std::string& path, const ReadOptions& options) {
  // 1. The file's text (the largest development file is 1.3 MB: read it whole).
  Result<std::string> text = internal::ReadTextFile(path, "dataset file");
  if (!text.ok()) return text.status();

  // 2. Lines that carry records (not blank, not '#' comments), with their 1-based numbers.
  std::vector<SourceLine> lines = internal::SplitLines(path, *text);
  std::erase_if(lines, [](const SourceLine& line) { return !line.IsRecord(); });

  // 3. Format, then one reader call per line.
  DatasetFormat format = options.format;
  if (format == DatasetFormat::kAuto) {
    Result<DatasetFormat> detected = DetectFormat(path, lines);
    if (!detected.ok()) return detected.status();
    format = *detected;
  }
  internal::DatasetBuilder builder(path, format);
  for (const SourceLine& line : lines)
    SLAMD_RETURN_IF_ERROR(ReadLine(format, options, line, &builder));
  return std::move(builder).Finish(options);
}

}  // namespace slamd::core
