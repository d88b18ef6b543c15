// Drawing a PlotScene with Cairo to a PNG, SVG or PDF file.
//
// The picture: a title (two lines: PlotScene::title and subtitle) at the top, a plot area with a
// light grid, axes ticked in metres at "nice" steps (1, 2 or 5 × 10^k) and titled by
// PlotScene::x_label / y_label, equal aspect (one metre is as long in x as in y, so the map is not
// distorted), a scale bar in the bottom-left corner of the plot area and a legend panel on the
// right (cameras, points, robots, landmarks, loop closures, ellipses; entries only for what the
// scene holds). Robots take the Okabe-Ito colour-blind-safe palette in order (blue, orange, bluish
// green, vermillion, sky blue, reddish purple, yellow, black), cycling after eight. Loop closures
// are thin translucent grey segments; landmarks are small squares in the robot's colour with a
// dark edge; ellipses are outlined in the robot's colour with a faint fill. A reconstruction's
// points are small dots in their own colour, its cameras dark translucent wedges of a fixed size
// on the page (their ellipses dark too), under everything else. Units: PNG in pixels; SVG and
// PDF in points, same numbers.
//
// Thread safety: the functions are reentrant (Cairo's toy font API is thread-safe).
#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>

#include "clients/slamctl/plot_scene.h"
#include "core/base/status.h"

namespace slamd::clients::plot {

enum class PlotFormat { kPng, kSvg, kPdf };

// "png", "svg", "pdf" (lower case) -> format; kInvalidArgument otherwise.
core::Result<PlotFormat> ParsePlotFormat(std::string_view name);
// From the file name's extension (case-insensitive): kInvalidArgument for any other (or none),
// with a message listing the accepted ones.
core::Result<PlotFormat> PlotFormatFromPath(const std::string& path);

struct RenderOptions {
  int width = 1200;   // pixels (PNG) or points (SVG, PDF). [200, 20000]
  int height = 900;   // [150, 20000]
  PlotFormat format = PlotFormat::kPng;

  core::Status Validate() const;
};

// A "nice" tick step for an axis spanning `range` metres with about `target` ticks:
// the 1, 2 or 5 × 10^k closest (in log scale) to range / target. range > 0, target >= 1.
double NiceStep(double range, int target);

// Where things go on the page for a scene and a page size: the plot area and the world-to-page
// map (uniform scale, y up). Exposed so tests can check pixels at known world positions.
struct PlotLayout {
  double area_x = 0.0, area_y = 0.0, area_w = 0.0, area_h = 0.0;  // plot area, page units
  double scale = 1.0;                           // page units per metre (same in x and y)
  Eigen::Vector2d world_center = Eigen::Vector2d::Zero();  // shown at the area's centre
  double legend_x = 0.0;                        // left edge of the legend panel
  double font = 12.0;                           // base font size, page units

  Eigen::Vector2d ToPage(const Eigen::Vector2d& world) const;
  // The world rectangle the plot area shows.
  Box VisibleWorld() const;
};
PlotLayout ComputeLayout(const PlotScene& scene, int width, int height);

// Draws `scene` into `path` in options.format. An empty scene draws axes around [-1, 1]².
// Errors: kInvalidArgument for invalid options, kIoError when the file cannot be written
// (the message includes Cairo's status string).
core::Status RenderScene(const PlotScene& scene, const std::string& path, const RenderOptions& options);

}  // namespace slamd::clients::plot
