// The format-independent entry points of sfm_io.h: ReadReconstruction and WritePly.
#include "core/io/sfm_io.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

#include "core/io/reader_internal.h"

namespace slamd::core {
namespace {

// "x y z r g b\n" of one PLY vertex.
void AppendPlyVertex(const Point3& p, const std::array<std::uint8_t, 3>& rgb, std::string* out) {
  internal::AppendNumber(p.x(), out);
  internal::AppendNumbers({p.y(), p.z()}, out);
  for (const std::uint8_t c : rgb) out->append(" ").append(std::to_string(c));
  out->push_back('\n');
}

}  // namespace

Result<Reconstruction> ReadReconstruction(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return ReadColmapText(path);
  return ReadBal(path);
}

Status WritePly(const Reconstruction& r, const std::string& path) {
  if (Status valid = r.Validate(); !valid.ok()) {
    return InvalidArgument("WritePly: " + valid.message());
  }
  std::string out =
      "ply\n"
      "format ascii 1.0\n"
      "comment slamd reconstruction: " +
      std::to_string(r.points.size()) + " points, then " + std::to_string(r.images.size()) +
      " camera centres in red\n"
      "element vertex " +
      std::to_string(r.points.size() + r.images.size()) +
      "\n"
      "property double x\n"
      "property double y\n"
      "property double z\n"
      "property uchar red\n"
      "property uchar green\n"
      "property uchar blue\n"
      "end_header\n";
  for (const SfmPoint& p : r.points) AppendPlyVertex(p.position, p.color, &out);
  for (const SfmImage& image : r.images) {
    AppendPlyVertex(image.pose.translation(), {255, 0, 0}, &out);
  }
  return internal::WriteTextFile(path, out, "WritePly");
}

}  // namespace slamd::core
