// Cairo rendering of a PlotScene. Steps: 1. layout (plot area, world-to-page map), 2. the plot
// area (grid, reconstruction, loop closures, ellipses, trajectories, landmarks; clipped),
// 3. frame, ticks and axis labels, 4. scale bar, 5. title, 6. legend.
#include "clients/slamctl/plot_render.h"

#include <cairo-pdf.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>

namespace slamd::clients::plot {
namespace {

struct Rgb {
  double r, g, b;
};
// Okabe & Ito (2008), "Color Universal Design": distinguishable under the common colour-vision
// deficiencies. Yellow comes late: it is the weakest on white.
constexpr std::array<Rgb, 8> kPalette = {{{0.0, 114 / 255.0, 178 / 255.0},
                                          {230 / 255.0, 159 / 255.0, 0.0},
                                          {0.0, 158 / 255.0, 115 / 255.0},
                                          {213 / 255.0, 94 / 255.0, 0.0},
                                          {86 / 255.0, 180 / 255.0, 233 / 255.0},
                                          {204 / 255.0, 121 / 255.0, 167 / 255.0},
                                          {240 / 255.0, 228 / 255.0, 66 / 255.0},
                                          {0.0, 0.0, 0.0}}};
constexpr Rgb kLoopColor{0.35, 0.35, 0.35};
constexpr double kLoopAlpha = 0.35;
constexpr Rgb kCameraColor{0.1, 0.1, 0.1};
constexpr double kCameraFillAlpha = 0.2;

Rgb RobotColor(std::size_t i) { return kPalette[i % kPalette.size()]; }

void SetColor(cairo_t* cr, const Rgb& c, double alpha = 1.0) {
  cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha);
}

// Draws `text` with its anchor at (x, y): ax = 0 left, 0.5 centre, 1 right; vertically centred
// on y (by the ink extents of digits, so labels of a row line up).
void Text(cairo_t* cr, double x, double y, const std::string& text, double ax) {
  cairo_text_extents_t ext;
  cairo_text_extents(cr, text.c_str(), &ext);
  cairo_text_extents_t digits;
  cairo_text_extents(cr, "0", &digits);
  cairo_move_to(cr, x - ax * ext.x_advance, y - (digits.y_bearing + digits.height / 2));
  cairo_show_text(cr, text.c_str());
}

void SetFont(cairo_t* cr, double size, bool bold = false) {
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size);
}

// A tick value with as many decimals as the step needs, never "-0".
std::string TickLabel(double v, double step) {
  if (std::abs(v) < step * 1e-6) v = 0.0;
  const int decimals = step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// An ellipse path in page units (y down), line width unaffected by the transform.
void EllipsePath(cairo_t* cr, const PlotLayout& L, const Ellipse& e) {
  const Eigen::Vector2d c = L.ToPage(e.center);
  // Cairo refuses a singular matrix: give degenerate axes a quarter of a unit.
  const double a = std::max(e.semi_major * L.scale, 0.25), b = std::max(e.semi_minor * L.scale, 0.25);
  cairo_save(cr);
  cairo_translate(cr, c.x(), c.y());
  cairo_rotate(cr, -e.angle);  // y is flipped: counter-clockwise in the world is clockwise here
  cairo_scale(cr, a, b);
  cairo_new_sub_path(cr);
  cairo_arc(cr, 0.0, 0.0, 1.0, 0.0, 2 * std::numbers::pi);
  cairo_close_path(cr);
  cairo_restore(cr);
}

void Square(cairo_t* cr, const Eigen::Vector2d& p, double half) {
  cairo_rectangle(cr, p.x() - half, p.y() - half, 2 * half, 2 * half);
}

// A camera's glyph: a translucent wedge from its centre (a dot) `length` long, closed by a thick
// line (the image plane) on the side it looks to.
void DrawCamera(cairo_t* cr, const Eigen::Vector2d& apex, const PlotCamera& camera, double length,
                double u) {
  // y is flipped on the page.
  const Eigen::Vector2d left =
      apex + length * Eigen::Vector2d(camera.left_edge.x(), -camera.left_edge.y());
  const Eigen::Vector2d right =
      apex + length * Eigen::Vector2d(camera.right_edge.x(), -camera.right_edge.y());
  cairo_new_path(cr);
  cairo_move_to(cr, apex.x(), apex.y());
  cairo_line_to(cr, left.x(), left.y());
  cairo_line_to(cr, right.x(), right.y());
  cairo_close_path(cr);
  SetColor(cr, kCameraColor, kCameraFillAlpha);
  cairo_fill_preserve(cr);
  SetColor(cr, kCameraColor);
  cairo_set_line_width(cr, 0.7 * u);
  cairo_stroke(cr);
  cairo_move_to(cr, left.x(), left.y());
  cairo_line_to(cr, right.x(), right.y());
  cairo_set_line_width(cr, 2.2 * u);
  cairo_stroke(cr);
  cairo_new_sub_path(cr);
  cairo_arc(cr, apex.x(), apex.y(), 1.8 * u, 0.0, 2 * std::numbers::pi);
  cairo_fill(cr);
}

// A reconstruction: points under the camera ellipses, the cameras' wedges on top.
void DrawReconstruction(cairo_t* cr, const PlotReconstruction& rec, const PlotLayout& L, double u) {
  const double dot = std::max(0.8, 1.3 * u);
  for (const PlotPoint& p : rec.points) {
    const Eigen::Vector2d q = L.ToPage(p.position);
    cairo_set_source_rgba(cr, p.color[0] / 255.0, p.color[1] / 255.0, p.color[2] / 255.0, 0.85);
    cairo_new_sub_path(cr);
    cairo_arc(cr, q.x(), q.y(), dot, 0.0, 2 * std::numbers::pi);
    cairo_fill(cr);
  }
  if (!rec.camera_ellipses.empty()) {
    cairo_set_line_width(cr, 0.9 * u);
    for (const Ellipse& e : rec.camera_ellipses) EllipsePath(cr, L, e);
    SetColor(cr, kCameraColor, 0.12);
    cairo_fill_preserve(cr);
    SetColor(cr, kCameraColor, 0.85);
    cairo_stroke(cr);
  }
  for (const PlotCamera& c : rec.cameras) DrawCamera(cr, L.ToPage(c.center), c, 16.0 * u, u);
}

// 2. Everything inside the plot area.
void DrawData(cairo_t* cr, const PlotScene& scene, const PlotLayout& L, double u, double step) {
  cairo_save(cr);
  cairo_rectangle(cr, L.area_x, L.area_y, L.area_w, L.area_h);
  cairo_clip(cr);
  // Grid at the ticks.
  const Box view = L.VisibleWorld();
  cairo_set_source_rgb(cr, 0.9, 0.9, 0.9);
  cairo_set_line_width(cr, 0.8 * u);
  for (double x = std::ceil(view.min.x() / step) * step; x <= view.max.x(); x += step) {
    const double px = L.ToPage({x, 0.0}).x();
    cairo_move_to(cr, px, L.area_y);
    cairo_line_to(cr, px, L.area_y + L.area_h);
  }
  for (double y = std::ceil(view.min.y() / step) * step; y <= view.max.y(); y += step) {
    const double py = L.ToPage({0.0, y}).y();
    cairo_move_to(cr, L.area_x, py);
    cairo_line_to(cr, L.area_x + L.area_w, py);
  }
  cairo_stroke(cr);

  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  DrawReconstruction(cr, scene.reconstruction, L, u);
  // Ellipses.
  cairo_set_line_width(cr, 0.9 * u);
  for (std::size_t i = 0; i < scene.robots.size(); ++i) {
    const PlotRobot& r = scene.robots[i];
    for (const auto* list : {&r.pose_ellipses, &r.landmark_ellipses}) {
      for (const Ellipse& e : *list) EllipsePath(cr, L, e);
    }
    SetColor(cr, RobotColor(i), 0.12);
    cairo_fill_preserve(cr);
    SetColor(cr, RobotColor(i), 0.85);
    cairo_stroke(cr);
  }
  // Loop closures over the ellipses, under the trajectories.
  SetColor(cr, kLoopColor, kLoopAlpha);
  cairo_set_line_width(cr, 0.7 * u);
  for (const PlotRobot& r : scene.robots) {
    for (const auto& [a, b] : r.loop_closures) {
      const Eigen::Vector2d pa = L.ToPage(a), pb = L.ToPage(b);
      cairo_move_to(cr, pa.x(), pa.y());
      cairo_line_to(cr, pb.x(), pb.y());
    }
    cairo_stroke(cr);
  }
  // Trajectories, each with a dot at its start.
  for (std::size_t i = 0; i < scene.robots.size(); ++i) {
    const PlotRobot& r = scene.robots[i];
    if (r.trajectory.empty()) continue;
    SetColor(cr, RobotColor(i));
    cairo_set_line_width(cr, std::max(1.2, 1.6 * u));  // visible at small sizes too
    const Eigen::Vector2d p0 = L.ToPage(r.trajectory.front());
    cairo_move_to(cr, p0.x(), p0.y());
    for (const Eigen::Vector2d& p : r.trajectory) {
      const Eigen::Vector2d q = L.ToPage(p);
      cairo_line_to(cr, q.x(), q.y());
    }
    cairo_stroke(cr);
    cairo_new_sub_path(cr);
    cairo_arc(cr, p0.x(), p0.y(), 3.5 * u, 0.0, 2 * std::numbers::pi);
    cairo_fill(cr);
  }
  // Landmarks on top.
  cairo_set_line_width(cr, 0.6 * u);
  for (std::size_t i = 0; i < scene.robots.size(); ++i) {
    for (const Eigen::Vector2d& p : scene.robots[i].landmarks) Square(cr, L.ToPage(p), 2.6 * u);
    SetColor(cr, RobotColor(i));
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
    cairo_stroke(cr);
  }
  cairo_restore(cr);
}

// 3. Frame, ticks, tick labels and axis titles.
void DrawAxes(cairo_t* cr, const PlotScene& scene, const PlotLayout& L, double u, double step) {
  const Box view = L.VisibleWorld();
  cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
  cairo_set_line_width(cr, 1.0 * u);
  cairo_rectangle(cr, L.area_x, L.area_y, L.area_w, L.area_h);
  cairo_stroke(cr);
  SetFont(cr, L.font * 0.9);
  const double tick = 5.0 * u, bottom = L.area_y + L.area_h;
  for (double x = std::ceil(view.min.x() / step) * step; x <= view.max.x(); x += step) {
    const double px = L.ToPage({x, 0.0}).x();
    cairo_move_to(cr, px, bottom);
    cairo_line_to(cr, px, bottom + tick);
    cairo_stroke(cr);
    Text(cr, px, bottom + tick + L.font * 0.8, TickLabel(x, step), 0.5);
  }
  for (double y = std::ceil(view.min.y() / step) * step; y <= view.max.y(); y += step) {
    const double py = L.ToPage({0.0, y}).y();
    cairo_move_to(cr, L.area_x, py);
    cairo_line_to(cr, L.area_x - tick, py);
    cairo_stroke(cr);
    Text(cr, L.area_x - tick - 0.4 * L.font, py, TickLabel(y, step), 1.0);
  }
  SetFont(cr, L.font);
  Text(cr, L.area_x + L.area_w / 2, bottom + tick + L.font * 2.3, scene.x_label, 0.5);
  cairo_save(cr);
  cairo_translate(cr, L.area_x - L.font * 4.3, L.area_y + L.area_h / 2);
  cairo_rotate(cr, -std::numbers::pi / 2);
  Text(cr, 0.0, 0.0, scene.y_label, 0.5);
  cairo_restore(cr);
}

// 4. A bar of a round length (about a fifth of the view) in the bottom-left corner.
void DrawScaleBar(cairo_t* cr, const PlotLayout& L, double u) {
  const double view_w = L.area_w / L.scale;
  double length = NiceStep(view_w, 5);
  while (length * L.scale > 0.3 * L.area_w) length /= 2;  // keep it short on narrow views
  const double bar = length * L.scale, pad = 0.6 * L.font;
  const double x0 = L.area_x + 1.2 * L.font, y0 = L.area_y + L.area_h - 1.2 * L.font;
  char label[64];
  std::snprintf(label, sizeof label, "%g m", length);
  SetFont(cr, L.font * 0.9);
  cairo_text_extents_t ext;
  cairo_text_extents(cr, label, &ext);
  const double box_w = std::max(bar, ext.x_advance) + 2 * pad, box_h = 2.4 * L.font;
  cairo_set_source_rgba(cr, 1.0, 1.0, 1.0, 0.85);
  cairo_rectangle(cr, x0 - pad, y0 - box_h + pad, box_w, box_h);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
  cairo_set_line_width(cr, 2.0 * u);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
  cairo_move_to(cr, x0, y0 - 4 * u);
  cairo_line_to(cr, x0, y0);
  cairo_line_to(cr, x0 + bar, y0);
  cairo_line_to(cr, x0 + bar, y0 - 4 * u);
  cairo_stroke(cr);
  Text(cr, x0 + bar / 2, y0 - 0.9 * L.font, label, 0.5);
}

// 5. Title and subtitle, centred over the plot area.
void DrawTitle(cairo_t* cr, const PlotScene& scene, const PlotLayout& L) {
  const double cx = L.area_x + L.area_w / 2;
  cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
  SetFont(cr, L.font * 1.35, true);
  Text(cr, cx, L.font * 1.5, scene.title, 0.5);
  if (!scene.subtitle.empty()) {
    cairo_set_source_rgb(cr, 0.3, 0.3, 0.3);
    SetFont(cr, L.font);
    Text(cr, cx, L.font * 3.1, scene.subtitle, 0.5);
  }
}

std::string Shorten(const std::string& s, std::size_t n) {
  return s.size() <= n ? s : s.substr(0, n - 3) + "...";
}

// 6. The legend: one entry per robot, then what the scene holds.
void DrawLegend(cairo_t* cr, const PlotScene& scene, const PlotLayout& L, double u) {
  const double x = L.legend_x, row = 1.6 * L.font, swatch = 1.8 * L.font;
  double y = L.area_y + 0.9 * L.font;
  SetFont(cr, L.font * 0.9);
  const auto label = [&](const std::string& text) {
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    Text(cr, x + swatch + 0.5 * L.font, y, text, 0.0);
    y += row;
  };
  for (std::size_t i = 0; i < scene.robots.size(); ++i) {
    SetColor(cr, RobotColor(i));
    cairo_set_line_width(cr, 2.0 * u);
    cairo_move_to(cr, x, y);
    cairo_line_to(cr, x + swatch, y);
    cairo_stroke(cr);
    label(Shorten(scene.robots[i].name, 26));
  }
  char buf[96];
  const PlotReconstruction& rec = scene.reconstruction;
  if (!rec.cameras.empty()) {
    const PlotCamera glyph{.left_edge = {0.9, 0.45}, .right_edge = {0.9, -0.45}};
    DrawCamera(cr, {x + 0.15 * swatch, y}, glyph, 0.8 * swatch, u);
    std::snprintf(buf, sizeof buf, "cameras (%zu)", rec.cameras.size());
    label(buf);
  }
  if (!rec.points.empty()) {
    cairo_new_path(cr);
    cairo_arc(cr, x + swatch / 2, y, 2.0 * u, 0.0, 2 * std::numbers::pi);
    cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
    cairo_fill(cr);
    std::snprintf(buf, sizeof buf, "points (%zu)", rec.points.size());
    label(buf);
  }
  if (const std::size_t n = scene.NumLandmarks(); n > 0) {
    Square(cr, {x + swatch / 2, y}, 2.6 * u);
    SetColor(cr, scene.robots.size() == 1 ? RobotColor(0) : Rgb{0.6, 0.6, 0.6});
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.15, 0.15, 0.15);
    cairo_set_line_width(cr, 0.6 * u);
    cairo_stroke(cr);
    std::snprintf(buf, sizeof buf, "landmarks (%zu)", n);
    label(buf);
  }
  if (const std::size_t n = scene.NumLoopClosures(); n > 0) {
    SetColor(cr, kLoopColor, std::min(1.0, 2 * kLoopAlpha));
    cairo_set_line_width(cr, 1.0 * u);
    cairo_move_to(cr, x, y);
    cairo_line_to(cr, x + swatch, y);
    cairo_stroke(cr);
    std::snprintf(buf, sizeof buf, "loop closures (%zu)", n);
    label(buf);
  }
  if (scene.NumEllipses() > 0) {
    const Rgb c = scene.robots.size() == 1 ? RobotColor(0)
                  : scene.robots.empty()   ? kCameraColor
                                           : Rgb{0.4, 0.4, 0.4};
    cairo_new_path(cr);  // show_text left a current point: no line from it to the arc
    cairo_save(cr);
    cairo_translate(cr, x + swatch / 2, y);
    cairo_scale(cr, swatch / 2, 0.45 * L.font);
    cairo_arc(cr, 0.0, 0.0, 1.0, 0.0, 2 * std::numbers::pi);
    cairo_restore(cr);
    SetColor(cr, c, 0.12);
    cairo_fill_preserve(cr);
    SetColor(cr, c, 0.85);
    cairo_set_line_width(cr, 0.9 * u);
    cairo_stroke(cr);
    std::snprintf(buf, sizeof buf, "%g\xcf\x83 x-y covariance", scene.sigma);  // σ in UTF-8
    label(buf);
  }
  // A light frame around the entries.
  cairo_set_source_rgb(cr, 0.75, 0.75, 0.75);
  cairo_set_line_width(cr, 0.8 * u);
  cairo_rectangle(cr, x - 0.5 * L.font, L.area_y, 14.0 * L.font, y - L.area_y - 0.6 * L.font);
  cairo_stroke(cr);
}

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};

core::Status CairoError(const std::string& path, cairo_status_t status) {
  return core::IoError("cannot write " + path + ": " + cairo_status_to_string(status));
}

}  // namespace

core::Result<PlotFormat> ParsePlotFormat(std::string_view name) {
  if (name == "png") return PlotFormat::kPng;
  if (name == "svg") return PlotFormat::kSvg;
  if (name == "pdf") return PlotFormat::kPdf;
  return core::InvalidArgument("unknown plot format '" + std::string(name) + "' (use png, svg or pdf)");
}

core::Result<PlotFormat> PlotFormatFromPath(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  std::string ext;
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash)) ext = path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  core::Result<PlotFormat> format = ParsePlotFormat(ext);
  if (!format.ok()) {
    return core::InvalidArgument("cannot tell the picture format from '" + path +
                                 "': name it *.png, *.svg or *.pdf, or pass --format");
  }
  return format;
}

core::Status RenderOptions::Validate() const {
  if (width < 200 || width > 20000 || height < 150 || height > 20000) {
    return core::InvalidArgument("picture size " + std::to_string(width) + "x" + std::to_string(height) +
                                 " out of range (width 200..20000, height 150..20000)");
  }
  return core::Status::Ok();
}

double NiceStep(double range, int target) {
  const double raw = range / std::max(target, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double best = magnitude, best_err = 1e300;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    const double err = std::abs(std::log(raw / (m * magnitude)));
    if (err < best_err) {
      best_err = err;
      best = m * magnitude;
    }
  }
  return best;
}

Eigen::Vector2d PlotLayout::ToPage(const Eigen::Vector2d& world) const {
  return {area_x + area_w / 2 + (world.x() - world_center.x()) * scale,
          area_y + area_h / 2 - (world.y() - world_center.y()) * scale};
}

Box PlotLayout::VisibleWorld() const {
  const Eigen::Vector2d half(area_w / 2 / scale, area_h / 2 / scale);
  Box box;
  box.Add(world_center - half);
  box.Add(world_center + half);
  return box;
}

PlotLayout ComputeLayout(const PlotScene& scene, int width, int height) {
  PlotLayout L;
  const double u = std::min(width / 1200.0, height / 900.0);  // 1 at the default size
  L.font = std::max(8.0, 14.0 * u);
  const double top = (scene.subtitle.empty() ? 3.0 : 4.4) * L.font, bottom = 3.6 * L.font;
  const double left = 5.2 * L.font, legend_w = 15.0 * L.font;
  L.legend_x = width - legend_w + 0.6 * L.font;
  L.area_x = left;
  L.area_y = top;
  L.area_w = std::max(10.0, width - legend_w - left - 0.6 * L.font);
  L.area_h = std::max(10.0, height - top - bottom);
  Box box = scene.Bounds();
  if (box.empty()) {
    box.Add(Eigen::Vector2d(-1.0, -1.0));
    box.Add(Eigen::Vector2d(1.0, 1.0));
  }
  Eigen::Vector2d size = box.max - box.min;
  // A 5% margin of the larger side (1 m for a single point) so nothing touches the frame.
  const double pad = size.maxCoeff() > 0.0 ? 0.05 * size.maxCoeff() : 1.0;
  size.array() += 2 * pad;
  L.scale = std::min(L.area_w / size.x(), L.area_h / size.y());
  L.world_center = (box.min + box.max) / 2;
  return L;
}

core::Status RenderScene(const PlotScene& scene, const std::string& path, const RenderOptions& options) {
  SLAMD_RETURN_IF_ERROR(options.Validate());
  const int w = options.width, h = options.height;
  std::unique_ptr<cairo_surface_t, SurfaceDeleter> surface;
  switch (options.format) {
    case PlotFormat::kPng:
      surface.reset(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, w, h));
      break;
    case PlotFormat::kSvg:
      surface.reset(cairo_svg_surface_create(path.c_str(), w, h));
      break;
    case PlotFormat::kPdf:
      surface.reset(cairo_pdf_surface_create(path.c_str(), w, h));
      break;
  }
  if (cairo_surface_status(surface.get()) != CAIRO_STATUS_SUCCESS) {
    return CairoError(path, cairo_surface_status(surface.get()));
  }
  {
    std::unique_ptr<cairo_t, ContextDeleter> context(cairo_create(surface.get()));
    cairo_t* cr = context.get();
    // 1. Layout; u scales line widths and marks with the page.
    const PlotLayout L = ComputeLayout(scene, w, h);
    const double u = std::max(0.5, std::min(w / 1200.0, h / 900.0));
    const Box view = L.VisibleWorld();
    const double step = NiceStep(view.max.x() - view.min.x(), std::max(2, static_cast<int>(L.area_w / (7 * L.font))));
    cairo_set_source_rgb(cr, 1.0, 1.0, 1.0);
    cairo_paint(cr);
    DrawData(cr, scene, L, u, step);   // 2.
    DrawAxes(cr, scene, L, u, step);   // 3.
    DrawScaleBar(cr, L, u);            // 4.
    DrawTitle(cr, scene, L);           // 5.
    DrawLegend(cr, scene, L, u);       // 6.
    if (cairo_status(cr) != CAIRO_STATUS_SUCCESS) return CairoError(path, cairo_status(cr));
  }
  if (options.format == PlotFormat::kPng) {
    const cairo_status_t written = cairo_surface_write_to_png(surface.get(), path.c_str());
    if (written != CAIRO_STATUS_SUCCESS) return CairoError(path, written);
  }
  cairo_surface_finish(surface.get());  // SVG and PDF are written here
  if (cairo_surface_status(surface.get()) != CAIRO_STATUS_SUCCESS) {
    return CairoError(path, cairo_surface_status(surface.get()));
  }
  return core::Status::Ok();
}

}  // namespace slamd::clients::plot
