#include "mlmap/pictures/map_image.h"

#include "mlmap/core/atomic_file.h"
#include "mlmap/pictures/png_codec.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace mlmap::pictures {
namespace {

// ---- Look ---------------------------------------------------------------------------------------

const cv::Scalar kBackground(255, 255, 255);
const cv::Scalar kGrid(232, 232, 232);
const cv::Scalar kFrame(110, 110, 110);
const cv::Scalar kTextColor(35, 35, 35);
const cv::Scalar kMutedTextColor(110, 110, 110);
const cv::Scalar kTrajectory(25, 25, 25);
const cv::Scalar kTrajectoryHalo(255, 255, 255);

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kLabelScale = 0.45;
constexpr double kTitleScale = 0.7;
constexpr double kMessageScale = 0.8;

constexpr int kMinMapWidth_px = 480;
constexpr int kMinMapHeight_px = 360;
constexpr int kMapPadding_px = 16;   ///< empty space between the data and the map frame
constexpr int kOuterMargin_px = 14;  ///< space between the image border and any content
constexpr int kTickLength_px = 5;
constexpr double kTickSpacing_px = 80.0;  ///< aimed-for distance between metre ticks
constexpr int kColorBarWidth_px = 18;
constexpr int kColorBarHeight_px = 240;
constexpr int kSwatch_px = 14;
/// Part of TURBO used for heights: its near-black ends are skipped so large low areas (floors)
/// and the dark trajectory stay distinguishable.
constexpr double kTurboLow = 0.1;
constexpr double kTurboHigh = 0.95;
constexpr double kFarFade = 0.65;        ///< side view: how much the farthest voxels fade to white
constexpr double kGridTolerance = 0.25;  ///< max off-grid offset of a voxel centre, in voxels

// ---- Small helpers ------------------------------------------------------------------------------

/// Index of the voxel axis shown horizontally / vertically / along the line of sight.
struct ViewAxes {
  int horizontal;
  int vertical;
  int depth;
};
constexpr ViewAxes kTopAxes{0, 1, 2};
constexpr ViewAxes kSideAxes{0, 2, 1};

long long floorDiv(long long a, long long b) {
  const long long q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

/// The 1/2/5 x 10^k value nearest to `raw` (> 0) on a log scale.
double niceStep(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double best = magnitude;
  for (const double factor : {1.0, 2.0, 5.0, 10.0}) {
    if (std::abs(std::log(factor * magnitude / raw)) < std::abs(std::log(best / raw))) {
      best = factor * magnitude;
    }
  }
  return best;
}

/// The largest 1/2/5 x 10^k value <= `raw` (> 0).
double niceFloor(double raw) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw) + 1e-9));
  for (const double factor : {5.0, 2.0, 1.0}) {
    if (factor * magnitude <= raw * (1.0 + 1e-9)) return factor * magnitude;
  }
  return magnitude;
}

/// Number of decimals needed to print multiples of `step` exactly.
int decimalsFor(double step) {
  const int decimals = static_cast<int>(-std::floor(std::log10(step) + 1e-9));
  return std::clamp(decimals, 0, 6);
}

std::string formatNumber(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  std::string text = buffer;
  if (text.rfind('-', 0) == 0 && text.find_first_not_of("-0.") == std::string::npos) {
    text.erase(0, 1);  // no "-0.0"
  }
  return text;
}

/// Multiples of `step` inside [lo, hi].
std::vector<double> ticksIn(double lo, double hi, double step) {
  std::vector<double> ticks;
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + step * 1e-9; k += 1.0) {
    ticks.push_back(k * step);
    if (ticks.size() > 1000) break;
  }
  return ticks;
}

cv::Size textSize(const std::string& text, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, thickness, &baseline);
}

enum class HAlign { kLeft, kCenter, kRight };
enum class VAlign { kTop, kMiddle, kBottom };

/// Draws text aligned at `anchor`; returns the box it occupies.
cv::Rect drawText(cv::Mat& image, const std::string& text, cv::Point anchor, HAlign h, VAlign v,
                  double scale, const cv::Scalar& color, int thickness = 1) {
  const cv::Size size = textSize(text, scale, thickness);
  int x = anchor.x;
  if (h == HAlign::kCenter) x -= size.width / 2;
  if (h == HAlign::kRight) x -= size.width;
  int y = anchor.y;  // baseline
  if (v == VAlign::kTop) y += size.height;
  if (v == VAlign::kMiddle) y += size.height / 2;
  cv::putText(image, text, {x, y}, kFont, scale, color, thickness, cv::LINE_AA);
  return {x, y - size.height, size.width, size.height};
}

const cv::Mat& turboLut() {
  static const cv::Mat lut = [] {
    cv::Mat ramp(256, 1, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(i) = static_cast<std::uint8_t>(i);
    cv::Mat colors;
    cv::applyColorMap(ramp, colors, cv::COLORMAP_TURBO);
    return colors;
  }();
  return lut;
}

cv::Scalar toScalar(const cv::Vec3b& c) { return {double(c[0]), double(c[1]), double(c[2])}; }

cv::Scalar fadeToWhite(const cv::Scalar& c, double amount) {
  return {c[0] + (255.0 - c[0]) * amount, c[1] + (255.0 - c[1]) * amount,
          c[2] + (255.0 - c[2]) * amount};
}

void drawStartMarker(cv::Mat& image, cv::Point center) {
  cv::circle(image, center, 6, cv::Scalar(255, 255, 255), cv::FILLED, cv::LINE_AA);
  cv::circle(image, center, 6, kTrajectory, 2, cv::LINE_AA);
}

void drawEndMarker(cv::Mat& image, cv::Point center) {
  const cv::Rect box(center.x - 5, center.y - 5, 11, 11);
  cv::rectangle(image, box, cv::Scalar(255, 255, 255), 4);
  cv::rectangle(image, box, kTrajectory, cv::FILLED);
}

// ---- Voxel grid ---------------------------------------------------------------------------------

using Index3 = Eigen::Matrix<long long, 3, 1>;

struct Index3Hash {
  std::size_t operator()(const Index3& i) const {
    std::size_t h = std::hash<long long>()(i.x());
    h = h * 1000003u ^ std::hash<long long>()(i.y());
    h = h * 1000003u ^ std::hash<long long>()(i.z());
    return h;
  }
};

/// The common grid of the voxels being drawn: voxel (0,0,0) has its lower corner at `anchor_W`.
struct Grid {
  double resolution_m = 0.1;
  Eigen::Vector3d anchor_W = Eigen::Vector3d::Zero();

  [[nodiscard]] Index3 indexOf(const Eigen::Vector3d& center_W, const char* list_name) const {
    Index3 index;
    for (int a = 0; a < 3; ++a) {
      const double f = (center_W[a] - anchor_W[a]) / resolution_m - 0.5;
      const double rounded = std::round(f);
      if (std::abs(f - rounded) > kGridTolerance || std::abs(rounded) > 1e15) {
        throw std::invalid_argument(std::string("map image: ") + list_name +
                                    " voxel centres are not on one grid of resolution " +
                                    formatNumber(resolution_m, 6) + " m");
      }
      index[a] = static_cast<long long>(rounded);
    }
    return index;
  }
};

void checkFinite(const std::vector<Eigen::Vector3d>& points, const char* what) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw std::invalid_argument(std::string("map image: ") + what + " point " +
                                  std::to_string(i) + " is not finite");
    }
  }
}

void checkList(const VoxelList& list, const char* name) {
  if (list.centers_W.empty()) return;
  if (!(list.resolution_m > 0.0) || !std::isfinite(list.resolution_m)) {
    throw std::invalid_argument(std::string("map image: ") + name +
                                " voxel resolution must be positive and finite, got " +
                                std::to_string(list.resolution_m));
  }
  checkFinite(list.centers_W, name);
}

void checkOptions(const MapImageOptions& options) {
  if (options.pixels_per_voxel < 1) {
    throw std::invalid_argument("map image: pixels_per_voxel must be >= 1, got " +
                                std::to_string(options.pixels_per_voxel));
  }
  checkFinite(options.trajectory_W, "trajectory");
}

// ---- Legend -------------------------------------------------------------------------------------

/// A column of legend entries, measured first, drawn once the layout is known.
class Legend {
 public:
  void header(const std::string& text) { items_.push_back({Kind::kHeader, text, {}, 0.0, 0.0}); }
  void text(const std::string& text) { items_.push_back({Kind::kText, text, {}, 0.0, 0.0}); }
  void swatch(const cv::Scalar& color, const std::string& text) {
    items_.push_back({Kind::kSwatch, text, color, 0.0, 0.0});
  }
  void trajectoryEntries() {
    items_.push_back({Kind::kLine, "trajectory", {}, 0.0, 0.0});
    items_.push_back({Kind::kStart, "start", {}, 0.0, 0.0});
    items_.push_back({Kind::kEnd, "end", {}, 0.0, 0.0});
  }
  void colorBar(double lo_m, double hi_m, int height_px) {
    bar_height_px_ = height_px;
    items_.push_back({Kind::kColorBar, "", {}, lo_m, hi_m});
  }
  void gap() { items_.push_back({Kind::kGap, "", {}, 0.0, 0.0}); }

  [[nodiscard]] bool empty() const { return items_.empty(); }

  [[nodiscard]] cv::Size size() const {
    int width = 0;
    int height = 0;
    for (const Item& item : items_) {
      const cv::Size s = itemSize(item);
      width = std::max(width, s.width);
      height += s.height;
    }
    return {width, height};
  }

  void draw(cv::Mat& image, cv::Point top_left) const {
    int y = top_left.y;
    for (const Item& item : items_) {
      const cv::Size s = itemSize(item);
      drawItem(image, item, {top_left.x, y}, s);
      y += s.height;
    }
  }

 private:
  enum class Kind { kHeader, kText, kSwatch, kLine, kStart, kEnd, kColorBar, kGap };
  struct Item {
    Kind kind;
    std::string text;
    cv::Scalar color;
    double lo_m;
    double hi_m;
  };
  static constexpr int kRow_px = 22;
  static constexpr int kSymbol_px = 26;  ///< room for the symbol left of an entry's text

  [[nodiscard]] std::vector<double> barTicks(const Item& item) const {
    const double range = item.hi_m - item.lo_m;
    const double step = niceStep(range / std::max(2.0, bar_height_px_ / 50.0));
    return ticksIn(item.lo_m, item.hi_m, step);
  }
  [[nodiscard]] int barDecimals(const Item& item) const {
    const double range = item.hi_m - item.lo_m;
    return decimalsFor(niceStep(range / std::max(2.0, bar_height_px_ / 50.0)));
  }

  [[nodiscard]] cv::Size itemSize(const Item& item) const {
    switch (item.kind) {
      case Kind::kHeader:
      case Kind::kText:
        return {textSize(item.text, kLabelScale).width, kRow_px};
      case Kind::kSwatch:
      case Kind::kLine:
      case Kind::kStart:
      case Kind::kEnd:
        return {kSymbol_px + textSize(item.text, kLabelScale).width, kRow_px};
      case Kind::kColorBar: {
        int label_width = 0;
        for (const double tick : barTicks(item)) {
          label_width = std::max(
              label_width, textSize(formatNumber(tick, barDecimals(item)), kLabelScale).width);
        }
        return {kColorBarWidth_px + kTickLength_px + 4 + label_width, bar_height_px_ + 16};
      }
      case Kind::kGap:
        return {0, 12};
    }
    return {0, 0};
  }

  void drawItem(cv::Mat& image, const Item& item, cv::Point at, cv::Size size) const {
    const int middle = at.y + size.height / 2;
    const cv::Point text_at(at.x + kSymbol_px, middle);
    switch (item.kind) {
      case Kind::kHeader:
        drawText(image, item.text, {at.x, middle}, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kTextColor, 1);
        break;
      case Kind::kText:
        drawText(image, item.text, {at.x, middle}, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kMutedTextColor);
        break;
      case Kind::kSwatch:
        cv::rectangle(image, cv::Rect(at.x + 2, middle - kSwatch_px / 2, kSwatch_px, kSwatch_px),
                      item.color, cv::FILLED);
        cv::rectangle(image, cv::Rect(at.x + 2, middle - kSwatch_px / 2, kSwatch_px, kSwatch_px),
                      kFrame, 1);
        drawText(image, item.text, text_at, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kTextColor);
        break;
      case Kind::kLine:
        cv::line(image, {at.x, middle}, {at.x + 18, middle}, kTrajectory, 1, cv::LINE_AA);
        drawText(image, item.text, text_at, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kTextColor);
        break;
      case Kind::kStart:
        drawStartMarker(image, {at.x + 9, middle});
        drawText(image, item.text, text_at, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kTextColor);
        break;
      case Kind::kEnd:
        drawEndMarker(image, {at.x + 9, middle});
        drawText(image, item.text, text_at, HAlign::kLeft, VAlign::kMiddle, kLabelScale,
                 kTextColor);
        break;
      case Kind::kColorBar: {
        const int top = at.y + 8;
        const int height = bar_height_px_;
        for (int r = 0; r < height; ++r) {
          const double fraction = height > 1 ? double(height - 1 - r) / (height - 1) : 0.0;
          cv::line(image, {at.x, top + r}, {at.x + kColorBarWidth_px - 1, top + r},
                   toScalar(heightColorBgr(fraction)));
        }
        cv::rectangle(image, cv::Rect(at.x, top, kColorBarWidth_px, height), kFrame, 1);
        const double range = item.hi_m - item.lo_m;
        for (const double tick : barTicks(item)) {
          const int y =
              top + static_cast<int>(std::lround((item.hi_m - tick) / range * (height - 1)));
          const int x = at.x + kColorBarWidth_px;
          cv::line(image, {x, y}, {x + kTickLength_px - 1, y}, kFrame, 1);
          drawText(image, formatNumber(tick, barDecimals(item)), {x + kTickLength_px + 3, y},
                   HAlign::kLeft, VAlign::kMiddle, kLabelScale, kTextColor);
        }
        break;
      }
      case Kind::kGap:
        break;
    }
  }

  std::vector<Item> items_;
  int bar_height_px_ = 200;
};

// ---- Layout and decorations ---------------------------------------------------------------------

/// Voxels of one view, already indexed on the grid, plus the trajectory in metres.
struct ViewContent {
  Grid grid;
  ViewAxes axes;
  std::vector<Index3> indices;              ///< all voxels that will be drawn (for the extent)
  std::vector<Eigen::Vector2d> trajectory;  ///< (horizontal, vertical) metres
};

/// Pixel layout of a view: which grid cells the map area shows and where it sits in the image.
struct Layout {
  long long voxels_per_cell = 1;
  int pixels_per_cell = 1;
  long long cell_lo_h = 0;
  long long cell_hi_h = 0;
  long long cell_lo_v = 0;
  long long cell_hi_v = 0;
  MapImageGeometry geometry;
  cv::Size image_size;
  cv::Point legend_at;
  int title_baseline_y = 0;

  [[nodiscard]] cv::Rect cellRect(long long cell_h, long long cell_v) const {
    const cv::Rect& area = geometry.map_area_px;
    return {area.x + static_cast<int>(cell_h - cell_lo_h) * pixels_per_cell,
            area.y + static_cast<int>(cell_hi_v - cell_v) * pixels_per_cell, pixels_per_cell,
            pixels_per_cell};
  }
  [[nodiscard]] cv::Point2d toImage(const Eigen::Vector2d& p) const {
    const MapImageGeometry& g = geometry;
    return {
        g.map_area_px.x + (p.x() - g.horizontal_min_m) / g.metres_per_pixel,
        g.map_area_px.y + g.map_area_px.height - (p.y() - g.vertical_min_m) / g.metres_per_pixel};
  }
};

struct AxisLabels {
  std::string horizontal;
  std::string vertical;
};

/// Chooses the scale and the extent of the map area, and the size of the whole image.
Layout makeLayout(const ViewContent& view, const MapImageOptions& options, const Legend& legend,
                  const AxisLabels& labels) {
  const double res = view.grid.resolution_m;
  // Extent in voxel units (inclusive), over voxels and trajectory.
  double lo_h = std::numeric_limits<double>::infinity();
  double hi_h = -lo_h;
  double lo_v = lo_h;
  double hi_v = -lo_h;
  for (const Index3& i : view.indices) {
    lo_h = std::min(lo_h, double(i[view.axes.horizontal]));
    hi_h = std::max(hi_h, double(i[view.axes.horizontal]));
    lo_v = std::min(lo_v, double(i[view.axes.vertical]));
    hi_v = std::max(hi_v, double(i[view.axes.vertical]));
  }
  for (const Eigen::Vector2d& p : view.trajectory) {
    const double h = std::floor((p.x() - view.grid.anchor_W[view.axes.horizontal]) / res);
    const double v = std::floor((p.y() - view.grid.anchor_W[view.axes.vertical]) / res);
    lo_h = std::min(lo_h, h);
    hi_h = std::max(hi_h, h);
    lo_v = std::min(lo_v, v);
    hi_v = std::max(hi_v, v);
  }
  if (!(lo_h <= hi_h)) {  // nothing at all: one voxel around the anchor
    lo_h = hi_h = lo_v = hi_v = 0.0;
  }
  const double span_voxels = std::max(hi_h - lo_h, hi_v - lo_v) + 1.0;
  const double usable_px = kMaxMapSide_px - 2.0 * kMapPadding_px;
  if (span_voxels > 1e9) {
    throw std::invalid_argument("map image: the map spans more than 1e9 voxels");
  }

  Layout layout;
  if (span_voxels * options.pixels_per_voxel <= usable_px) {
    layout.pixels_per_cell = options.pixels_per_voxel;
  } else if (span_voxels <= usable_px) {
    layout.pixels_per_cell = std::max(1, static_cast<int>(usable_px / span_voxels));
  } else {
    layout.pixels_per_cell = 1;
    layout.voxels_per_cell = static_cast<long long>(std::ceil(span_voxels / usable_px));
  }
  const long long k = layout.voxels_per_cell;
  const int ppc = layout.pixels_per_cell;
  layout.cell_lo_h = floorDiv(static_cast<long long>(lo_h), k);
  layout.cell_hi_h = floorDiv(static_cast<long long>(hi_h), k);
  layout.cell_lo_v = floorDiv(static_cast<long long>(lo_v), k);
  layout.cell_hi_v = floorDiv(static_cast<long long>(hi_v), k);
  // Padding, then grow symmetrically to the minimum map size.
  const long long pad = (kMapPadding_px + ppc - 1) / ppc;
  const auto grow = [&](long long& lo, long long& hi, int min_px) {
    lo -= pad;
    hi += pad;
    const long long cells = hi - lo + 1;
    const long long min_cells = (min_px + ppc - 1) / ppc;
    if (cells < min_cells) {
      const long long extra = min_cells - cells;
      lo -= extra / 2;
      hi += extra - extra / 2;
    }
  };
  grow(layout.cell_lo_h, layout.cell_hi_h, kMinMapWidth_px);
  grow(layout.cell_lo_v, layout.cell_hi_v, kMinMapHeight_px);

  const int map_w = static_cast<int>(layout.cell_hi_h - layout.cell_lo_h + 1) * ppc;
  const int map_h = static_cast<int>(layout.cell_hi_v - layout.cell_lo_v + 1) * ppc;
  const double cell_m = res * double(k);

  MapImageGeometry& g = layout.geometry;
  g.metres_per_pixel = cell_m / ppc;
  g.horizontal_min_m = view.grid.anchor_W[view.axes.horizontal] + double(layout.cell_lo_h) * cell_m;
  g.vertical_min_m = view.grid.anchor_W[view.axes.vertical] + double(layout.cell_lo_v) * cell_m;
  g.pixels_per_voxel = k == 1 ? ppc : 0;

  // Margins: title on top, vertical axis name above the frame, tick labels left and below,
  // scale bar under those, legend on the right.
  const int label_h = textSize("0", kLabelScale).height;
  int tick_label_w = 0;
  {
    const double step_v = niceStep(kTickSpacing_px * g.metres_per_pixel);
    for (const double t :
         ticksIn(g.vertical_min_m, g.vertical_min_m + map_h * g.metres_per_pixel, step_v)) {
      tick_label_w =
          std::max(tick_label_w, textSize(formatNumber(t, decimalsFor(step_v)), kLabelScale).width);
    }
  }
  const int title_h = options.title.empty() ? 0 : textSize(options.title, kTitleScale, 2).height;
  const int top = kOuterMargin_px + (title_h > 0 ? title_h + 14 : 0) + label_h + 10;
  const int left = kOuterMargin_px + std::max(tick_label_w + kTickLength_px + 6,
                                              textSize(labels.vertical, kLabelScale).width / 2);
  const int bottom = kTickLength_px + 6 + label_h + 16 + 28 + kOuterMargin_px;
  const cv::Size legend_size = legend.empty() ? cv::Size(0, 0) : legend.size();
  const int right = (legend.empty() ? 0 : 24 + legend_size.width) + kOuterMargin_px + 8;

  g.map_area_px = cv::Rect(left, top, map_w, map_h);
  layout.legend_at = cv::Point(left + map_w + 24, top);
  const int width = std::max(left + map_w + right,
                             2 * kOuterMargin_px + textSize(options.title, kTitleScale, 2).width);
  const int height = std::max(top + map_h + bottom, top + legend_size.height + kOuterMargin_px);
  layout.image_size = cv::Size(width, height);
  layout.title_baseline_y = kOuterMargin_px + title_h;
  return layout;
}

/// Metre grid (under the voxels).
void drawGrid(cv::Mat& image, const Layout& layout) {
  const MapImageGeometry& g = layout.geometry;
  const cv::Rect& area = g.map_area_px;
  const double step = niceStep(kTickSpacing_px * g.metres_per_pixel);
  for (const double t :
       ticksIn(g.horizontal_min_m, g.horizontal_min_m + area.width * g.metres_per_pixel, step)) {
    const int x = static_cast<int>(std::lround(layout.toImage({t, 0.0}).x));
    cv::line(image, {x, area.y}, {x, area.y + area.height - 1}, kGrid, 1);
  }
  for (const double t :
       ticksIn(g.vertical_min_m, g.vertical_min_m + area.height * g.metres_per_pixel, step)) {
    const int y = static_cast<int>(std::lround(layout.toImage({0.0, t}).y));
    cv::line(image, {area.x, y}, {area.x + area.width - 1, y}, kGrid, 1);
  }
}

/// Frame, ticks, axis names, scale bar and title (over the voxels).
void drawDecorations(cv::Mat& image, const Layout& layout, const MapImageOptions& options,
                     const AxisLabels& labels) {
  const MapImageGeometry& g = layout.geometry;
  const cv::Rect& area = g.map_area_px;
  cv::rectangle(image, cv::Rect(area.x - 1, area.y - 1, area.width + 2, area.height + 2), kFrame,
                1);

  const double step = niceStep(kTickSpacing_px * g.metres_per_pixel);
  const int decimals = decimalsFor(step);
  const int bottom = area.y + area.height;
  // Horizontal axis name at the right end of the tick-label row; labels it would hit are skipped.
  const cv::Size name_size = textSize(labels.horizontal, kLabelScale);
  const int name_left = area.x + area.width - name_size.width;
  drawText(image, labels.horizontal, {area.x + area.width, bottom + kTickLength_px + 5},
           HAlign::kRight, VAlign::kTop, kLabelScale, kTextColor);
  for (const double t :
       ticksIn(g.horizontal_min_m, g.horizontal_min_m + area.width * g.metres_per_pixel, step)) {
    const int x = static_cast<int>(std::lround(layout.toImage({t, 0.0}).x));
    cv::line(image, {x, bottom}, {x, bottom + kTickLength_px}, kFrame, 1);
    const std::string text = formatNumber(t, decimals);
    if (x + textSize(text, kLabelScale).width / 2 + 8 >= name_left) continue;
    drawText(image, text, {x, bottom + kTickLength_px + 5}, HAlign::kCenter, VAlign::kTop,
             kLabelScale, kTextColor);
  }
  for (const double t :
       ticksIn(g.vertical_min_m, g.vertical_min_m + area.height * g.metres_per_pixel, step)) {
    const int y = static_cast<int>(std::lround(layout.toImage({0.0, t}).y));
    cv::line(image, {area.x - 1 - kTickLength_px, y}, {area.x - 1, y}, kFrame, 1);
    drawText(image, formatNumber(t, decimals), {area.x - kTickLength_px - 5, y}, HAlign::kRight,
             VAlign::kMiddle, kLabelScale, kTextColor);
  }
  const int label_h = textSize("0", kLabelScale).height;
  // Vertical axis name above the frame's top-left corner.
  drawText(image, labels.vertical, {area.x, area.y - 9}, HAlign::kCenter, VAlign::kBottom,
           kLabelScale, kTextColor);
  const int second_row = bottom + kTickLength_px + 5 + label_h + 16;

  // Scale bar: at most a quarter of the map width, 1/2/5 x 10^k metres.
  const double bar_m = niceFloor(area.width * g.metres_per_pixel / 4.0);
  const int bar_px = static_cast<int>(std::lround(bar_m / g.metres_per_pixel));
  const int y = second_row + 6;
  const int x0 = area.x;
  cv::rectangle(image, cv::Rect(x0, y - 2, bar_px, 5), kTrajectory, cv::FILLED);
  cv::line(image, {x0, y - 6}, {x0, y + 6}, kTrajectory, 1);
  cv::line(image, {x0 + bar_px - 1, y - 6}, {x0 + bar_px - 1, y + 6}, kTrajectory, 1);
  drawText(image, formatNumber(bar_m, decimalsFor(bar_m)) + " m", {x0 + bar_px + 10, y},
           HAlign::kLeft, VAlign::kMiddle, kLabelScale, kTextColor);

  if (!options.title.empty()) {
    cv::putText(image, options.title, {kOuterMargin_px, layout.title_baseline_y}, kFont,
                kTitleScale, kTextColor, 2, cv::LINE_AA);
  }
}

void drawTrajectory(cv::Mat& image, const Layout& layout, const ViewContent& view) {
  if (view.trajectory.empty()) return;
  constexpr int kShift = 4;
  constexpr double kScale = 1 << kShift;
  std::vector<cv::Point> points;
  points.reserve(view.trajectory.size());
  for (const Eigen::Vector2d& p : view.trajectory) {
    const cv::Point2d q = layout.toImage(p);
    points.emplace_back(static_cast<int>(std::lround((q.x - 0.5) * kScale)),
                        static_cast<int>(std::lround((q.y - 0.5) * kScale)));
  }
  const std::vector<std::vector<cv::Point>> lines{points};
  cv::polylines(image, lines, false, kTrajectoryHalo, 3, cv::LINE_AA, kShift);
  cv::polylines(image, lines, false, kTrajectory, 1, cv::LINE_AA, kShift);
  const auto pixel = [&](const cv::Point& p) {
    return cv::Point(static_cast<int>(std::lround(p.x / kScale)),
                     static_cast<int>(std::lround(p.y / kScale)));
  };
  drawStartMarker(image, pixel(points.front()));
  drawEndMarker(image, pixel(points.back()));
}

void drawCenteredMessage(cv::Mat& image, const Layout& layout, const std::string& message) {
  const cv::Rect& area = layout.geometry.map_area_px;
  const cv::Point center(area.x + area.width / 2, area.y + area.height / 2);
  const cv::Size size = textSize(message, kMessageScale, 1);
  cv::rectangle(image,
                cv::Rect(center.x - size.width / 2 - 10, center.y - size.height / 2 - 10,
                         size.width + 20, size.height + 20),
                kBackground, cv::FILLED);
  drawText(image, message, center, HAlign::kCenter, VAlign::kMiddle, kMessageScale,
           kMutedTextColor);
}

std::vector<Eigen::Vector2d> projectTrajectory(const MapImageOptions& options, ViewAxes axes) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(options.trajectory_W.size());
  for (const Eigen::Vector3d& p : options.trajectory_W) {
    out.emplace_back(p[axes.horizontal], p[axes.vertical]);
  }
  return out;
}

Grid gridOf(const VoxelList& list) {
  Grid grid;
  if (!list.centers_W.empty()) {
    grid.resolution_m = list.resolution_m;
    grid.anchor_W = list.centers_W.front() - Eigen::Vector3d::Constant(0.5 * list.resolution_m);
  }
  return grid;
}

std::string voxelSummary(std::size_t count, double resolution_m) {
  return std::to_string(count) + " voxels of " +
         formatNumber(resolution_m, std::max(2, decimalsFor(resolution_m) + 1)) + " m";
}

/// Shared body of renderTopDown() and renderSide().
cv::Mat renderHeightView(const VoxelList& occupied, const MapImageOptions& options,
                         MapImageGeometry* geometry, ViewAxes axes) {
  checkOptions(options);
  checkList(occupied, "occupied");
  const bool side = axes.vertical == 2;

  ViewContent view{gridOf(occupied), axes, {}, projectTrajectory(options, axes)};
  view.indices.reserve(occupied.centers_W.size());
  for (const Eigen::Vector3d& c : occupied.centers_W) {
    view.indices.push_back(view.grid.indexOf(c, "occupied"));
  }

  // Colour range over the voxel centre heights.
  double z_lo = 0.0;
  double z_hi = 0.0;
  double depth_lo = 0.0;
  double depth_hi = 0.0;
  if (!occupied.centers_W.empty()) {
    z_lo = depth_lo = std::numeric_limits<double>::infinity();
    z_hi = depth_hi = -z_lo;
    for (const Eigen::Vector3d& c : occupied.centers_W) {
      z_lo = std::min(z_lo, c.z());
      z_hi = std::max(z_hi, c.z());
      depth_lo = std::min(depth_lo, c[axes.depth]);
      depth_hi = std::max(depth_hi, c[axes.depth]);
    }
    if (z_hi - z_lo < 0.5 * occupied.resolution_m) {
      z_lo -= 0.5 * occupied.resolution_m;
      z_hi += 0.5 * occupied.resolution_m;
    }
  }

  Legend legend;
  if (options.legend) {
    if (!occupied.centers_W.empty()) {
      legend.header(side ? "height z [m]" : "top height z [m]");
      legend.colorBar(z_lo, z_hi, kColorBarHeight_px);
      if (side) legend.text("paler = farther (+y)");
      legend.gap();
    }
    if (!options.trajectory_W.empty()) {
      legend.trajectoryEntries();
      legend.gap();
    }
    if (!occupied.centers_W.empty())
      legend.text(voxelSummary(occupied.centers_W.size(), occupied.resolution_m));
  }
  const AxisLabels labels{"x [m]", side ? "z [m]" : "y [m]"};
  Layout layout = makeLayout(view, options, legend, labels);
  layout.geometry.color_min_m = z_lo;
  layout.geometry.color_max_m = z_hi;

  cv::Mat image(layout.image_size, CV_8UC3, kBackground);
  drawGrid(image, layout);

  // The visible voxel of each map cell: the highest (top-down), or the nearest and then the
  // highest (side), as painting them all low before high / far before near would show; its
  // colour depends only on its height (and distance), so ties look the same. Found in one pass
  // over the voxels, then each cell filled once.
  const auto& centers = occupied.centers_W;
  const auto shownOver = [&](std::size_t a, std::size_t b) {
    if (!side) return centers[a].z() > centers[b].z();
    return centers[a][axes.depth] < centers[b][axes.depth] ||
           (centers[a][axes.depth] == centers[b][axes.depth] && centers[a].z() > centers[b].z());
  };
  const long long cells_v = layout.cell_hi_v - layout.cell_lo_v + 1;
  const long long cells = (layout.cell_hi_h - layout.cell_lo_h + 1) * cells_v;
  constexpr std::size_t kNoVoxel = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> shown(occupied.centers_W.empty() ? 0 : static_cast<std::size_t>(cells),
                                 kNoVoxel);
  for (std::size_t i = 0; i < centers.size(); ++i) {
    const Index3& index = view.indices[i];
    const long long h = floorDiv(index[axes.horizontal], layout.voxels_per_cell) - layout.cell_lo_h;
    const long long v = floorDiv(index[axes.vertical], layout.voxels_per_cell) - layout.cell_lo_v;
    std::size_t& cell = shown[static_cast<std::size_t>(h * cells_v + v)];
    if (cell == kNoVoxel || shownOver(i, cell)) cell = i;
  }
  const double z_range = z_hi - z_lo;
  const double depth_range = depth_hi - depth_lo;
  for (long long c = 0; c < static_cast<long long>(shown.size()); ++c) {
    const std::size_t i = shown[static_cast<std::size_t>(c)];
    if (i == kNoVoxel) continue;
    cv::Scalar color = toScalar(heightColorBgr((centers[i].z() - z_lo) / z_range));
    if (side && depth_range > 0.0) {
      color = fadeToWhite(color, kFarFade * (centers[i][axes.depth] - depth_lo) / depth_range);
    }
    // As cv::rectangle rounds a colour.
    const cv::Vec3b bgr(cv::saturate_cast<std::uint8_t>(color[0]),
                        cv::saturate_cast<std::uint8_t>(color[1]),
                        cv::saturate_cast<std::uint8_t>(color[2]));
    const cv::Rect cell =
        layout.cellRect(layout.cell_lo_h + c / cells_v, layout.cell_lo_v + c % cells_v) &
        cv::Rect(0, 0, image.cols, image.rows);
    for (int y = cell.y; y < cell.y + cell.height; ++y) {
      cv::Vec3b* row = image.ptr<cv::Vec3b>(y);
      std::fill(row + cell.x, row + cell.x + cell.width, bgr);
    }
  }

  drawTrajectory(image, layout, view);
  drawDecorations(image, layout, options, labels);
  if (!legend.empty()) legend.draw(image, layout.legend_at);
  if (occupied.centers_W.empty()) drawCenteredMessage(image, layout, "no occupied voxels");
  if (geometry != nullptr) *geometry = layout.geometry;
  return image;
}

}  // namespace

cv::Point MapImageGeometry::toPixel(double horizontal_m, double vertical_m) const {
  const double col = std::floor((horizontal_m - horizontal_min_m) / metres_per_pixel);
  const double row = std::floor((vertical_m - vertical_min_m) / metres_per_pixel);
  return {map_area_px.x + static_cast<int>(col),
          map_area_px.y + map_area_px.height - 1 - static_cast<int>(row)};
}

cv::Vec3b mapBackgroundBgr() { return {255, 255, 255}; }

cv::Vec3b mapGridBgr() { return {232, 232, 232}; }

cv::Vec3b heightColorBgr(double fraction) {
  const double clamped = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
  const double lut_position = kTurboLow + (kTurboHigh - kTurboLow) * clamped;
  return turboLut().at<cv::Vec3b>(static_cast<int>(std::lround(lut_position * 255.0)));
}

cv::Vec3b comparisonColorBgr(ComparisonClass cls) {
  switch (cls) {
    case ComparisonClass::kTruePositive:
      return {150, 175, 140};  // grey-green
    case ComparisonClass::kFalsePositive:
      return {40, 40, 215};  // red
    case ComparisonClass::kFalseNegative:
      return {215, 110, 30};  // blue
    case ComparisonClass::kBothErrors:
      return {190, 50, 190};  // magenta
  }
  return {0, 0, 0};
}

cv::Mat renderTopDown(const VoxelList& occupied, const MapImageOptions& options,
                      MapImageGeometry* geometry) {
  return renderHeightView(occupied, options, geometry, kTopAxes);
}

cv::Mat renderSide(const VoxelList& occupied, const MapImageOptions& options,
                   MapImageGeometry* geometry) {
  return renderHeightView(occupied, options, geometry, kSideAxes);
}

cv::Mat renderComparison(const VoxelList& mapped, const VoxelList& truth,
                         const MapImageOptions& options, MapImageGeometry* geometry) {
  checkOptions(options);
  checkList(mapped, "mapped");
  checkList(truth, "truth");
  if (!mapped.centers_W.empty() && !truth.centers_W.empty() &&
      std::abs(mapped.resolution_m - truth.resolution_m) >
          1e-9 * std::max(mapped.resolution_m, truth.resolution_m)) {
    throw std::invalid_argument("map image: mapped and truth resolutions differ (" +
                                formatNumber(mapped.resolution_m, 6) + " m vs " +
                                formatNumber(truth.resolution_m, 6) + " m)");
  }

  ViewContent view{gridOf(mapped.centers_W.empty() ? truth : mapped),
                   kTopAxes,
                   {},
                   projectTrajectory(options, kTopAxes)};
  std::unordered_set<Index3, Index3Hash> truth_set;
  truth_set.reserve(truth.centers_W.size());
  for (const Eigen::Vector3d& c : truth.centers_W) truth_set.insert(view.grid.indexOf(c, "truth"));
  std::unordered_set<Index3, Index3Hash> mapped_set;
  mapped_set.reserve(mapped.centers_W.size());
  for (const Eigen::Vector3d& c : mapped.centers_W)
    mapped_set.insert(view.grid.indexOf(c, "mapped"));

  enum : std::uint8_t { kTp = 1, kFp = 2, kFn = 4 };
  std::vector<std::pair<Index3, std::uint8_t>> voxels;  // union with class bits
  voxels.reserve(mapped_set.size() + truth_set.size());
  std::size_t tp = 0;
  std::size_t fp = 0;
  std::size_t fn = 0;
  for (const Index3& i : mapped_set) {
    const bool is_true = truth_set.count(i) > 0;
    voxels.emplace_back(i, is_true ? kTp : kFp);
    ++(is_true ? tp : fp);
  }
  for (const Index3& i : truth_set) {
    if (mapped_set.count(i) == 0) {
      voxels.emplace_back(i, kFn);
      ++fn;
    }
  }
  view.indices.reserve(voxels.size());
  for (const auto& v : voxels) view.indices.push_back(v.first);

  Legend legend;
  if (options.legend) {
    legend.header("columns (top-down)");
    legend.swatch(toScalar(comparisonColorBgr(ComparisonClass::kTruePositive)),
                  "correct: " + std::to_string(tp) + " TP");
    legend.swatch(toScalar(comparisonColorBgr(ComparisonClass::kFalsePositive)),
                  "map only: " + std::to_string(fp) + " FP");
    legend.swatch(toScalar(comparisonColorBgr(ComparisonClass::kFalseNegative)),
                  "truth only: " + std::to_string(fn) + " FN");
    legend.swatch(toScalar(comparisonColorBgr(ComparisonClass::kBothErrors)), "FP and FN");
    legend.text("counts are voxels");
    legend.gap();
    const auto ratio = [](std::size_t a, std::size_t b) {
      return b == 0 ? std::string("n/a") : formatNumber(double(a) / double(b), 3);
    };
    legend.text("precision " + ratio(tp, tp + fp));
    legend.text("recall    " + ratio(tp, tp + fn));
    legend.gap();
    if (!options.trajectory_W.empty()) {
      legend.trajectoryEntries();
      legend.gap();
    }
    legend.text(
        "voxel " +
        formatNumber(view.grid.resolution_m, std::max(2, decimalsFor(view.grid.resolution_m) + 1)) +
        " m");
  }
  const AxisLabels labels{"x [m]", "y [m]"};
  Layout layout = makeLayout(view, options, legend, labels);

  // Column classes.
  std::unordered_map<long long, std::uint8_t> columns;
  const auto columnKey = [&](long long h, long long v) {
    return (h - layout.cell_lo_h) * (layout.cell_hi_v - layout.cell_lo_v + 1) +
           (v - layout.cell_lo_v);
  };
  for (const auto& [index, bits] : voxels) {
    const long long h = floorDiv(index.x(), layout.voxels_per_cell);
    const long long v = floorDiv(index.y(), layout.voxels_per_cell);
    columns[columnKey(h, v)] |= bits;
  }

  cv::Mat image(layout.image_size, CV_8UC3, kBackground);
  drawGrid(image, layout);
  const long long rows = layout.cell_hi_v - layout.cell_lo_v + 1;
  for (const auto& [key, bits] : columns) {
    ComparisonClass cls = ComparisonClass::kTruePositive;
    if ((bits & kFp) && (bits & kFn)) {
      cls = ComparisonClass::kBothErrors;
    } else if (bits & kFp) {
      cls = ComparisonClass::kFalsePositive;
    } else if (bits & kFn) {
      cls = ComparisonClass::kFalseNegative;
    }
    const cv::Rect cell =
        layout.cellRect(layout.cell_lo_h + key / rows, layout.cell_lo_v + key % rows);
    cv::rectangle(image, cell, toScalar(comparisonColorBgr(cls)), cv::FILLED);
  }
  drawTrajectory(image, layout, view);
  drawDecorations(image, layout, options, labels);
  if (!legend.empty()) legend.draw(image, layout.legend_at);
  if (voxels.empty()) drawCenteredMessage(image, layout, "no voxels in either list");
  if (geometry != nullptr) *geometry = layout.geometry;
  return image;
}

void writePng(const std::string& path, const cv::Mat& image) {
  if (image.empty()) {
    throw std::runtime_error("writePng: refusing to write an empty image to '" + path + "'");
  }
  std::string bytes;
  try {
    bytes = encodePng(image);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("writePng: cannot write '" + path + "': " + e.what());
  }
  writeFileAtomically(path, bytes);
}

}  // namespace mlmap::pictures
