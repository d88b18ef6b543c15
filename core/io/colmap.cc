// COLMAP's text model: ReadColmapText and WriteColmapText. Layouts and conventions: sfm_io.h.
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>

#include "core/io/reader_internal.h"
#include "core/io/sfm_io.h"

namespace slamd::core {
namespace {

using internal::FieldName;
using internal::SourceLine;

constexpr std::uint64_t kMaxColmapId32 = std::numeric_limits<std::uint32_t>::max();
// COLMAP's invalid point id (2^64-1), written -1; real ids are below it.
constexpr std::uint64_t kNoPoint3D = std::numeric_limits<std::uint64_t>::max();

// The camera models slamd reads and writes (sfm_io.h), with COLMAP's parameter order.
enum class ColmapModel { kSimplePinhole, kPinhole, kSimpleRadial, kRadial, kOpenCv };

struct ColmapModelInfo {
  ColmapModel model;
  const char* name;
  int num_params;
  std::array<const char*, 8> params;
};

constexpr ColmapModelInfo kColmapModels[] = {
    {ColmapModel::kSimplePinhole, "SIMPLE_PINHOLE", 3, {"f", "cx", "cy"}},
    {ColmapModel::kPinhole, "PINHOLE", 4, {"fx", "fy", "cx", "cy"}},
    {ColmapModel::kSimpleRadial, "SIMPLE_RADIAL", 4, {"f", "cx", "cy", "k"}},
    {ColmapModel::kRadial, "RADIAL", 5, {"f", "cx", "cy", "k1", "k2"}},
    {ColmapModel::kOpenCv, "OPENCV", 8, {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"}},
};

const ColmapModelInfo* FindColmapModel(std::string_view name) {
  for (const ColmapModelInfo& info : kColmapModels) {
    if (name == info.name) return &info;
  }
  return nullptr;
}

const ColmapModelInfo& ColmapModelOf(ColmapModel model) {
  return kColmapModels[static_cast<int>(model)];
}

// The intrinsics of a camera line's parameters (p holds info.num_params numbers).
SfmIntrinsics IntrinsicsFromColmap(const ColmapModelInfo& info, const double* p) {
  SfmIntrinsics k;
  k.model = info.name;
  switch (info.model) {
    case ColmapModel::kSimplePinhole:
      k.calibration = Cal3_S2(p[0], p[0], 0.0, p[1], p[2]);
      break;
    case ColmapModel::kPinhole:
      k.calibration = Cal3_S2(p[0], p[1], 0.0, p[2], p[3]);
      break;
    case ColmapModel::kSimpleRadial:
      k.calibration = Cal3Bundler(p[0], p[3], 0.0);
      k.principal_point = Vector2(p[1], p[2]);
      break;
    case ColmapModel::kRadial:
      k.calibration = Cal3Bundler(p[0], p[3], p[4]);
      k.principal_point = Vector2(p[1], p[2]);
      break;
    case ColmapModel::kOpenCv:
      k.calibration = Cal3DS2(Cal3_S2(p[0], p[1], 0.0, p[2], p[3]), p[4], p[5], p[6], p[7]);
      break;
  }
  return k;
}

// Where the reader's pixels are measured from: the principal point for the Cal3Bundler models,
// the image corner otherwise (reconstruction.h).
Vector2 PixelOrigin(const SfmIntrinsics& k) {
  return std::holds_alternative<Cal3Bundler>(k.calibration) ? k.principal_point : Vector2::Zero();
}

// ---------------------------------------------------------------------------------------------
// Reading.

// A 2D point of images.txt: where, which 3-D point (kNoPoint3D: none), and whether that point's
// track has listed it yet.
struct ColmapKeypoint {
  Vector2 xy;
  std::uint64_t point3d = kNoPoint3D;
  bool in_track = false;
};

// What the three files' readers share while the Reconstruction is built.
struct ColmapReadState {
  std::string cameras_path, images_path, points_path;
  Reconstruction r;
  std::unordered_map<std::uint64_t, int> camera_index, image_index, point_index;  // id -> index
  std::vector<int> camera_lines, image_lines, point_lines;  // the line of each, by index
  std::vector<std::vector<ColmapKeypoint>> keypoints;       // by image index
  std::vector<int> keypoint_lines;                          // each image's second line
};

// Records `id` as the `index`-th entry of `ids`, or reports the first line that had it.
Status AddColmapId(const SourceLine& line, std::string_view what, std::uint64_t id, int index,
                   std::unordered_map<std::uint64_t, int>* ids, std::vector<int>* lines) {
  const auto [it, inserted] = ids->emplace(id, index);
  if (!inserted) {
    return line.Problem("duplicate " + std::string(what) + " " + std::to_string(id) +
                        " (first at line " + std::to_string((*lines)[it->second]) + ")");
  }
  lines->push_back(line.number());
  return Status::Ok();
}

// CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
Status ReadColmapCamera(const SourceLine& line, ColmapReadState* s) {
  if (line.num_fields() < 2) return line.Error("CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
  const ColmapModelInfo* info = FindColmapModel(line.field(1));
  if (info == nullptr) {
    return line.Problem("unknown camera model '" + std::string(line.field(1)) +
                        "' (slamd reads SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV)");
  }
  const int num_fields = 4 + info->num_params;
  if (line.num_fields() != num_fields) {
    std::string layout = std::string("CAMERA_ID ") + info->name + " WIDTH HEIGHT";
    for (int k = 0; k < info->num_params; ++k) layout.append(" ").append(info->params[k]);
    return line.Error(layout + " (" + std::to_string(num_fields) + " fields, not " +
                      std::to_string(line.num_fields()) + ")");
  }
  std::uint64_t id, width, height;
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(0, {"CAMERA_ID"}, kMaxColmapId32, &id));
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(2, {"WIDTH"}, std::numeric_limits<int>::max(), &width));
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(3, {"HEIGHT"}, std::numeric_limits<int>::max(), &height));
  double p[8];
  for (int k = 0; k < info->num_params; ++k) {
    SLAMD_RETURN_IF_ERROR(line.FieldNumber(4 + k, {info->params[k]}, &p[k]));
  }
  const int index = static_cast<int>(s->r.intrinsics.size());
  SLAMD_RETURN_IF_ERROR(
      AddColmapId(line, "CAMERA_ID", id, index, &s->camera_index, &s->camera_lines));
  SfmIntrinsics k = IntrinsicsFromColmap(*info, p);
  k.width = static_cast<int>(width);
  k.height = static_cast<int>(height);
  k.id = static_cast<std::uint32_t>(id);
  s->r.intrinsics.push_back(std::move(k));
  return Status::Ok();
}

// IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID [NAME]
Status ReadColmapImage(const SourceLine& line, ColmapReadState* s) {
  if (line.num_fields() != 9 && line.num_fields() != 10) {
    return line.Error(
        "IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields, or 9 without NAME, not " +
        std::to_string(line.num_fields()) + ")");
  }
  static constexpr const char* kFields[7] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
  std::uint64_t id, camera_id;
  double v[7];
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(0, {"IMAGE_ID"}, kMaxColmapId32, &id));
  for (int k = 0; k < 7; ++k) SLAMD_RETURN_IF_ERROR(line.FieldNumber(1 + k, {kFields[k]}, &v[k]));
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(8, {"CAMERA_ID"}, kMaxColmapId32, &camera_id));
  const auto camera = s->camera_index.find(camera_id);
  if (camera == s->camera_index.end()) {
    return line.Problem("unknown CAMERA_ID " + std::to_string(camera_id) + " (not in " +
                        s->cameras_path + ")");
  }
  Rot3 R_cw;
  SLAMD_RETURN_IF_ERROR(
      internal::RotationFromQuaternion(line, "QW QX QY QZ", v[0], v[1], v[2], v[3], &R_cw));
  const int index = static_cast<int>(s->r.images.size());
  SLAMD_RETURN_IF_ERROR(AddColmapId(line, "IMAGE_ID", id, index, &s->image_index, &s->image_lines));
  s->r.images.push_back({.pose = Pose3(R_cw, Point3(v[4], v[5], v[6])).Inverse(),
                         .intrinsics = camera->second,
                         .name = line.num_fields() == 10 ? std::string(line.field(9)) : "",
                         .id = static_cast<std::uint32_t>(id)});
  return Status::Ok();
}

// X Y POINT3D_ID triples: the 2D points of the image read last.
Status ReadColmapKeypoints(const SourceLine& line, ColmapReadState* s) {
  if (line.num_fields() % 3 != 0) {
    return line.Error(
        "the image's 2D points as X Y POINT3D_ID triples (a multiple of 3 fields, not " +
        std::to_string(line.num_fields()) + ")");
  }
  std::vector<ColmapKeypoint> keypoints(line.num_fields() / 3);
  for (int k = 0; k < static_cast<int>(keypoints.size()); ++k) {
    ColmapKeypoint& kp = keypoints[k];
    SLAMD_RETURN_IF_ERROR(line.FieldNumber(3 * k, {"X", "2D point", k}, &kp.xy.x()));
    SLAMD_RETURN_IF_ERROR(line.FieldNumber(3 * k + 1, {"Y", "2D point", k}, &kp.xy.y()));
    if (line.field(3 * k + 2) != "-1") {
      SLAMD_RETURN_IF_ERROR(line.FieldInteger(3 * k + 2, {"POINT3D_ID (or -1)", "2D point", k},
                                              kNoPoint3D - 1, &kp.point3d));
    }
  }
  s->keypoints.push_back(std::move(keypoints));
  s->keypoint_lines.push_back(line.number());
  return Status::Ok();
}

// POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID, POINT2D_IDX); the track is checked against
// the images' 2D points.
Status ReadColmapPoint(const SourceLine& line, ColmapReadState* s) {
  const int n = line.num_fields();
  if (n < 8 || (n - 8) % 2 != 0) {
    return line.Error(
        "POINT3D_ID X Y Z R G B ERROR, then IMAGE_ID POINT2D_IDX pairs (8 + an even number of "
        "fields, not " +
        std::to_string(n) + ")");
  }
  SfmPoint point;
  SLAMD_RETURN_IF_ERROR(line.FieldInteger(0, {"POINT3D_ID"}, kNoPoint3D - 1, &point.id));
  static constexpr const char* kXyz[3] = {"X", "Y", "Z"};
  for (int k = 0; k < 3; ++k) {
    SLAMD_RETURN_IF_ERROR(line.FieldNumber(1 + k, {kXyz[k]}, &point.position[k]));
  }
  static constexpr const char* kRgb[3] = {"R", "G", "B"};
  for (int k = 0; k < 3; ++k) {
    std::uint64_t c;
    SLAMD_RETURN_IF_ERROR(line.FieldInteger(4 + k, {kRgb[k]}, 255, &c));
    point.color[k] = static_cast<std::uint8_t>(c);
  }
  SLAMD_RETURN_IF_ERROR(line.FieldNumber(7, {"ERROR"}, &point.error));
  const int index = static_cast<int>(s->r.points.size());
  SLAMD_RETURN_IF_ERROR(
      AddColmapId(line, "POINT3D_ID", point.id, index, &s->point_index, &s->point_lines));

  for (int e = 0; e < (n - 8) / 2; ++e) {
    std::uint64_t image_id, idx;
    SLAMD_RETURN_IF_ERROR(
        line.FieldInteger(8 + 2 * e, {"IMAGE_ID", "track element", e}, kMaxColmapId32, &image_id));
    SLAMD_RETURN_IF_ERROR(line.FieldInteger(9 + 2 * e, {"POINT2D_IDX", "track element", e},
                                            std::numeric_limits<int>::max(), &idx));
    const std::string element = "track element " + std::to_string(e) + " (IMAGE_ID " +
                                std::to_string(image_id) + ", POINT2D_IDX " + std::to_string(idx) +
                                ")";
    const auto image = s->image_index.find(image_id);
    if (image == s->image_index.end()) {
      return line.Problem(element + ": unknown IMAGE_ID (not in " + s->images_path + ")");
    }
    std::vector<ColmapKeypoint>& keypoints = s->keypoints[image->second];
    const std::string image_line =
        s->images_path + ":" + std::to_string(s->keypoint_lines[image->second]);
    if (idx >= keypoints.size()) {
      return line.Problem(element + ": the image has " + std::to_string(keypoints.size()) +
                          " 2D points (" + image_line + ")");
    }
    ColmapKeypoint& kp = keypoints[idx];
    if (kp.point3d != point.id) {
      return line.Problem(element + " of POINT3D_ID " + std::to_string(point.id) + ": " +
                          image_line + " gives that 2D point POINT3D_ID " +
                          (kp.point3d == kNoPoint3D ? "-1" : std::to_string(kp.point3d)));
    }
    if (kp.in_track) return line.Problem(element + " is listed twice");
    kp.in_track = true;
  }
  s->r.points.push_back(point);
  return Status::Ok();
}

// Every 2D point that names a 3-D point must be in its track (ReadColmapPoint checked the other
// direction); then the observations, in images.txt order.
Status AddColmapObservations(ColmapReadState* s) {
  for (int i = 0; i < static_cast<int>(s->keypoints.size()); ++i) {
    const Vector2 origin = PixelOrigin(s->r.intrinsics[s->r.images[i].intrinsics]);
    const std::string where = s->images_path + ":" + std::to_string(s->keypoint_lines[i]) + ": ";
    for (int k = 0; k < static_cast<int>(s->keypoints[i].size()); ++k) {
      const ColmapKeypoint& kp = s->keypoints[i][k];
      if (kp.point3d == kNoPoint3D) continue;
      const auto point = s->point_index.find(kp.point3d);
      const std::string what =
          "2D point " + std::to_string(k) + " observes POINT3D_ID " + std::to_string(kp.point3d);
      if (point == s->point_index.end()) {
        return DataLoss(where + what + ", which is not in " + s->points_path);
      }
      if (!kp.in_track) {
        return DataLoss(where + what + ", but the point's track (" + s->points_path + ":" +
                        std::to_string(s->point_lines[point->second]) + ") does not list (" +
                        std::to_string(s->r.images[i].id) + ", " + std::to_string(k) + ")");
      }
      s->r.observations.push_back({.image = i, .point = point->second, .uv = kp.xy - origin});
    }
  }
  return Status::Ok();
}

// The record lines of one of the three files, each given to `read`. Images take two lines: the
// line after an image line is its 2D points, whatever it holds.
template <typename ReadLine>
Status ReadColmapFile(const std::string& path, bool two_line_records, ReadLine read) {
  Result<std::string> text = internal::ReadTextFile(path, "COLMAP file");
  if (!text.ok()) return text.status();
  const std::vector<SourceLine> lines = internal::SplitLines(path, *text);
  for (std::size_t n = 0; n < lines.size(); ++n) {
    if (!lines[n].IsRecord()) continue;
    SLAMD_RETURN_IF_ERROR(read(lines[n], false));
    if (!two_line_records) continue;
    if (n + 1 == lines.size()) {
      return lines[n].Problem(
          "expected the image's 2D points (X Y POINT3D_ID ...) on the next line, got the end of "
          "the file");
    }
    SLAMD_RETURN_IF_ERROR(read(lines[++n], true));
  }
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------
// Writing.

// The model and parameters `k` is written with, or what keeps it from being written.
Status ColmapParams(const SfmIntrinsics& k, std::size_t index, const ColmapModelInfo** info,
                    std::vector<double>* params) {
  if (k.model.empty()) {
    *info = &ColmapModelOf(std::holds_alternative<Cal3_S2>(k.calibration)   ? ColmapModel::kPinhole
                           : std::holds_alternative<Cal3DS2>(k.calibration) ? ColmapModel::kOpenCv
                                                                            : ColmapModel::kRadial);
  } else {
    *info = FindColmapModel(k.model);
  }
  const std::string where =
      "WriteColmapText: intrinsics " + std::to_string(index) + " (model '" + k.model + "'): ";
  if (*info == nullptr) {
    return InvalidArgument(where +
                           "not a model slamd writes (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, "
                           "RADIAL, OPENCV)");
  }
  const auto mismatch = [&](const char* type) {
    return InvalidArgument(where + "the model needs a " + type + " calibration");
  };
  switch ((*info)->model) {
    case ColmapModel::kSimplePinhole:
    case ColmapModel::kPinhole: {
      const Cal3_S2* K = std::get_if<Cal3_S2>(&k.calibration);
      if (K == nullptr) return mismatch("Cal3_S2");
      if (K->skew() != 0.0) return InvalidArgument(where + "COLMAP has no skew");
      if ((*info)->model == ColmapModel::kPinhole) {
        *params = {K->fx(), K->fy(), K->u0(), K->v0()};
      } else if (K->fx() == K->fy()) {
        *params = {K->fx(), K->u0(), K->v0()};
      } else {
        return InvalidArgument(where + "fx != fy (use PINHOLE)");
      }
      return Status::Ok();
    }
    case ColmapModel::kSimpleRadial:
    case ColmapModel::kRadial: {
      const Cal3Bundler* b = std::get_if<Cal3Bundler>(&k.calibration);
      if (b == nullptr) return mismatch("Cal3Bundler");
      const Vector2& c = k.principal_point;
      if ((*info)->model == ColmapModel::kRadial) {
        *params = {b->f(), c.x(), c.y(), b->k1(), b->k2()};
      } else if (b->k2() == 0.0) {
        *params = {b->f(), c.x(), c.y(), b->k1()};
      } else {
        return InvalidArgument(where + "k2 != 0 (use RADIAL)");
      }
      return Status::Ok();
    }
    case ColmapModel::kOpenCv: {
      const Cal3DS2* d = std::get_if<Cal3DS2>(&k.calibration);
      if (d == nullptr) return mismatch("Cal3DS2");
      const Cal3_S2 K = d->pinhole();
      if (K.skew() != 0.0) return InvalidArgument(where + "COLMAP has no skew");
      *params = {K.fx(), K.fy(), K.u0(), K.v0(), d->k1(), d->k2(), d->p1(), d->p2()};
      return Status::Ok();
    }
  }
  return Status::Ok();
}

// Ok when no two of `items` have the same id.
template <typename Item, typename Id>
Status CheckColmapIds(const std::vector<Item>& items, const char* what, const char* id_name,
                      Id id_of) {
  std::unordered_map<std::uint64_t, std::size_t> seen;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const std::uint64_t id = id_of(items[i]);
    const auto [it, inserted] = seen.emplace(id, i);
    if (!inserted) {
      return InvalidArgument("WriteColmapText: " + std::string(what) + " " +
                             std::to_string(it->second) + " and " + std::to_string(i) +
                             " have the same " + id_name + " " + std::to_string(id));
    }
  }
  return Status::Ok();
}

// What WriteColmapText can write (sfm_io.h), but for the intrinsics (ColmapParams): a valid
// reconstruction, ids unique within each file, names without blanks, point ids below COLMAP's
// invalid id.
Status CheckColmapRepresentable(const Reconstruction& r) {
  if (Status valid = r.Validate(); !valid.ok()) {
    return InvalidArgument("WriteColmapText: " + valid.message());
  }
  SLAMD_RETURN_IF_ERROR(CheckColmapIds(r.intrinsics, "intrinsics", "CAMERA_ID",
                                       [](const SfmIntrinsics& k) { return k.id; }));
  SLAMD_RETURN_IF_ERROR(
      CheckColmapIds(r.images, "images", "IMAGE_ID", [](const SfmImage& i) { return i.id; }));
  SLAMD_RETURN_IF_ERROR(
      CheckColmapIds(r.points, "points", "POINT3D_ID", [](const SfmPoint& p) { return p.id; }));
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    if (r.images[i].name.find_first_of(" \t\r\n\v\f") != std::string::npos) {
      return InvalidArgument("WriteColmapText: image " + std::to_string(i) + "'s name '" +
                             r.images[i].name + "' has a blank in it (COLMAP's NAME has none)");
    }
  }
  for (std::size_t j = 0; j < r.points.size(); ++j) {
    if (r.points[j].id == kNoPoint3D) {
      return InvalidArgument("WriteColmapText: point " + std::to_string(j) +
                             " has id 2^64-1, COLMAP's invalid point id");
    }
  }
  return Status::Ok();
}

// cameras.txt.
Status ColmapCameras(const Reconstruction& r, std::string* out) {
  *out =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: " +
      std::to_string(r.intrinsics.size()) + "\n";
  for (std::size_t i = 0; i < r.intrinsics.size(); ++i) {
    const SfmIntrinsics& k = r.intrinsics[i];
    const ColmapModelInfo* info;
    std::vector<double> params;
    SLAMD_RETURN_IF_ERROR(ColmapParams(k, i, &info, &params));
    out->append(std::to_string(k.id)).append(" ").append(info->name);
    out->append(" ").append(std::to_string(k.width)).append(" ").append(std::to_string(k.height));
    for (const double x : params) internal::AppendNumbers({x}, out);
    out->push_back('\n');
  }
  return Status::Ok();
}

std::string MeanText(std::size_t total, std::size_t count) {
  std::string out;
  internal::AppendNumber(count == 0 ? 0.0 : static_cast<double>(total) / count, &out);
  return out;
}

// images.txt; `keypoint_index[o]` is observation o's POINT2D_IDX in its image.
std::string ColmapImages(const Reconstruction& r, const std::vector<std::vector<int>>& by_image,
                         std::vector<int>* keypoint_index) {
  std::string out =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      "# Number of images: " +
      std::to_string(r.images.size()) +
      ", mean observations per image: " + MeanText(r.observations.size(), r.images.size()) + "\n";
  keypoint_index->assign(r.observations.size(), -1);
  for (std::size_t i = 0; i < r.images.size(); ++i) {
    const SfmImage& image = r.images[i];
    const SfmIntrinsics& k = r.intrinsics[image.intrinsics];
    const Pose3 T_cw = image.pose.Inverse();
    const Eigen::Quaterniond q = T_cw.rotation().ToQuaternion();
    const Point3& t = T_cw.translation();
    out.append(std::to_string(image.id));
    internal::AppendNumbers({q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()}, &out);
    out.append(" ").append(std::to_string(k.id));
    if (!image.name.empty()) out.append(" ").append(image.name);
    out.push_back('\n');
    const Vector2 origin = PixelOrigin(k);
    std::string keypoints;
    for (std::size_t n = 0; n < by_image[i].size(); ++n) {
      const int o = by_image[i][n];
      (*keypoint_index)[o] = static_cast<int>(n);
      const Vector2 xy = r.observations[o].uv + origin;
      internal::AppendNumbers({xy.x(), xy.y()}, &keypoints);
      keypoints.append(" ").append(std::to_string(r.points[r.observations[o].point].id));
    }
    // The fields without the leading blank (an empty line when the image has no observations).
    if (!keypoints.empty()) out.append(keypoints, 1);
    out.push_back('\n');
  }
  return out;
}

std::string ColmapPoints(const Reconstruction& r, const std::vector<std::vector<int>>& by_point,
                         const std::vector<int>& keypoint_index) {
  std::string out =
      "# 3D point list with one line of data per point:\n"
      "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      "# Number of points: " +
      std::to_string(r.points.size()) +
      ", mean track length: " + MeanText(r.observations.size(), r.points.size()) + "\n";
  for (std::size_t j = 0; j < r.points.size(); ++j) {
    const SfmPoint& p = r.points[j];
    out.append(std::to_string(p.id));
    internal::AppendNumbers({p.position.x(), p.position.y(), p.position.z()}, &out);
    for (const std::uint8_t c : p.color) out.append(" ").append(std::to_string(c));
    internal::AppendNumbers({p.error}, &out);
    for (const int o : by_point[j]) {
      out.append(" ").append(std::to_string(r.images[r.observations[o].image].id));
      out.append(" ").append(std::to_string(keypoint_index[o]));
    }
    out.push_back('\n');
  }
  return out;
}

}  // namespace

Result<Reconstruction> ReadColmapText(const std::string& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    return NotFound("COLMAP model directory '" + dir + "' not found");
  }
  ColmapReadState s;
  s.cameras_path = dir + "/cameras.txt";
  s.images_path = dir + "/images.txt";
  s.points_path = dir + "/points3D.txt";
  // 1. Cameras, 2. images and their 2D points, 3. points and their tracks (checked against the
  // 2D points), 4. observations (and the 2D points no track listed).
  SLAMD_RETURN_IF_ERROR(ReadColmapFile(s.cameras_path, false, [&](const SourceLine& line, bool) {
    return ReadColmapCamera(line, &s);
  }));
  SLAMD_RETURN_IF_ERROR(
      ReadColmapFile(s.images_path, true, [&](const SourceLine& line, bool second) {
        return second ? ReadColmapKeypoints(line, &s) : ReadColmapImage(line, &s);
      }));
  SLAMD_RETURN_IF_ERROR(ReadColmapFile(s.points_path, false, [&](const SourceLine& line, bool) {
    return ReadColmapPoint(line, &s);
  }));
  SLAMD_RETURN_IF_ERROR(AddColmapObservations(&s));
  return std::move(s.r);
}

Status WriteColmapText(const Reconstruction& r, const std::string& dir) {
  // 1. Everything checked and formatted first.
  SLAMD_RETURN_IF_ERROR(CheckColmapRepresentable(r));
  std::string cameras;
  SLAMD_RETURN_IF_ERROR(ColmapCameras(r, &cameras));
  std::vector<std::vector<int>> by_image(r.images.size()), by_point(r.points.size());
  for (std::size_t o = 0; o < r.observations.size(); ++o) {
    by_image[r.observations[o].image].push_back(static_cast<int>(o));
    by_point[r.observations[o].point].push_back(static_cast<int>(o));
  }
  std::vector<int> keypoint_index;
  const std::string images = ColmapImages(r, by_image, &keypoint_index);
  const std::string points = ColmapPoints(r, by_point, keypoint_index);

  // 2. The directory and the three files.
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    return IoError("WriteColmapText: cannot create directory '" + dir + "': " + ec.message());
  }
  constexpr const char* kWriter = "WriteColmapText";
  SLAMD_RETURN_IF_ERROR(internal::WriteTextFile(dir + "/cameras.txt", cameras, kWriter));
  SLAMD_RETURN_IF_ERROR(internal::WriteTextFile(dir + "/images.txt", images, kWriter));
  return internal::WriteTextFile(dir + "/points3D.txt", points, kWriter);
}

}  // namespace slamd::core
