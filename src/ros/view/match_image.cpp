#include "src/ros/view/match_image.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace bsf_vpr {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kMarginPx = 8;  // image border and vertical gaps; > kFramePx
constexpr int kFramePx = 3;   // accept-colour frame around the reference panel
constexpr int kPadPx = 6;     // inside the label block and placeholders
constexpr int kTickPx = 8;    // height of a true-place tick under the axis
const cv::Scalar kBackground(28, 28, 28);
const cv::Scalar kBlock(48, 48, 48);        // label block and plot strip
const cv::Scalar kPlaceholder(80, 80, 80);  // panel of a missing image
const cv::Scalar kText(255, 255, 255);
const cv::Scalar kNoteText(200, 200, 200);
const cv::Scalar kAxis(150, 150, 150);
const cv::Scalar kAccepted(60, 210, 60);   // BGR green
const cv::Scalar kRejected(0, 150, 255);   // BGR orange
const cv::Scalar kBars(235, 165, 70);      // BGR light blue
const cv::Scalar kTruePlace(255, 255, 0);  // BGR cyan

// A font size and its vertical metrics (pixels).
struct TextStyle {
  double scale = 1;
  int thickness = 1;
  int ascent_px = 0;  // baseline to top of capitals
  int line_px = 0;    // baseline to baseline, descenders and a gap included
};

TextStyle StyleForHeight(int height_px) {
  TextStyle s;
  s.scale = cv::getFontScaleFromHeight(kFont, height_px, s.thickness);
  int baseline = 0;
  s.ascent_px = cv::getTextSize("Ag", kFont, s.scale, s.thickness, &baseline).height;
  s.line_px = s.ascent_px + baseline + std::max(3, height_px / 3);
  return s;
}

TextStyle LabelStyle(const MatchImageOptions& o) { return StyleForHeight(o.text_height_px); }
TextStyle SmallStyle(const MatchImageOptions& o) {
  return StyleForHeight(std::max(6, o.text_height_px * 6 / 7));
}

int TextWidth(const std::string& text, const TextStyle& s) {
  int baseline = 0;
  return text.empty() ? 0 : cv::getTextSize(text, kFont, s.scale, s.thickness, &baseline).width;
}

// Writes text with its baseline's left end at origin.
void Put(cv::Mat& img, const std::string& text, cv::Point origin, const TextStyle& s,
         const cv::Scalar& colour) {
  cv::putText(img, text, origin, kFont, s.scale, colour, s.thickness, cv::LINE_AA);
}

// Rows of the plot strip above the data area (match marker) and below it (ticks, labels).
int PlotHeaderPx(const TextStyle& small) { return small.line_px + 2; }
int PlotFooterPx(const TextStyle& small) { return kTickPx + 6 + small.line_px; }

void CheckRange(const char* field, int value, int lo, int hi) {
  if (value < lo || value > hi) {
    throw std::invalid_argument("MatchImageOptions." + std::string(field) + " must be in [" +
                                std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                std::to_string(value));
  }
}

void CheckPlace(const std::string& what, int place, int num_places) {
  if (place < 0 || place >= num_places) {
    throw std::invalid_argument("match image: " + what + " = " + std::to_string(place) +
                                " is not a place in [0, " + std::to_string(num_places) + ")");
  }
}

void CheckImage(const char* field, const cv::Mat& image) {
  if (image.empty() || image.type() == CV_8UC3 || image.type() == CV_8UC1) return;
  throw std::invalid_argument("match image: " + std::string(field) + " must be CV_8UC3 or " +
                              "CV_8UC1, got " + cv::typeToString(image.type()));
}

void ValidateContent(const MatchImageContent& c) {
  if (c.num_places < 1) {
    throw std::invalid_argument("match image: num_places must be >= 1, got " +
                                std::to_string(c.num_places));
  }
  if (!c.posterior.empty() && c.posterior.size() != c.place_ids.size()) {
    throw std::invalid_argument("match image: posterior has " + std::to_string(c.posterior.size()) +
                                " entries but place_ids " + std::to_string(c.place_ids.size()) +
                                " (expected equal or empty)");
  }
  for (size_t k = 0; k < c.place_ids.size(); ++k) {
    CheckPlace("place_ids[" + std::to_string(k) + "]", c.place_ids[k], c.num_places);
  }
  for (size_t k = 0; k < c.posterior.size(); ++k) {
    if (!std::isfinite(c.posterior[k]) || c.posterior[k] < 0) {
      throw std::invalid_argument("match image: posterior[" + std::to_string(k) + "] = " +
                                  std::to_string(c.posterior[k]) + " is not a finite P >= 0");
    }
  }
  if (c.match != -1) CheckPlace("match", c.match, c.num_places);
  for (size_t k = 0; k < c.true_places.size(); ++k) {
    CheckPlace("true_places[" + std::to_string(k) + "]", c.true_places[k], c.num_places);
  }
  CheckImage("query", c.query);
  CheckImage("reference", c.reference);
}

// Size of a panel: the image scaled to panel_height_px (aspect kept, at most
// max_panel_width_px wide), or a 4:3 placeholder when there is no image.
cv::Size PanelSize(const cv::Mat& image, const MatchImageOptions& o) {
  const int h = o.panel_height_px;
  if (image.empty()) return {static_cast<int>(std::lround(h * 4.0 / 3.0)), h};
  const double aspect = static_cast<double>(image.cols) / image.rows;
  const int w = std::max(1, static_cast<int>(std::lround(h * aspect)));
  if (w <= o.max_panel_width_px) return {w, h};
  const int scaled_h = std::max(1, static_cast<int>(std::lround(o.max_panel_width_px / aspect)));
  return {o.max_panel_width_px, scaled_h};
}

std::string PlotLegend(const MatchImageContent& c, const MatchImageOptions& o) {
  std::ostringstream s;
  s.precision(3);
  if (c.posterior.empty()) {
    s << "place (bars: rank of " << c.place_ids.size() << ", best tallest)";
  } else {
    const float top = *std::max_element(c.posterior.begin(), c.posterior.end());
    s << "place (bars: " << (o.log_scale ? "log10 P" : "P") << ", top " << top
      << (o.log_scale ? ", log " + std::to_string(static_cast<int>(kLogDecades)) + " decades)"
                      : ")");
  }
  if (!c.true_places.empty()) s << ", cyan: true";
  return s.str();
}

// Width the plot strip needs for "0", the legend and "N-1" on one line.
int PlotMinWidth(const MatchImageContent& c, const MatchImageOptions& o) {
  const TextStyle small = SmallStyle(o);
  return TextWidth("0", small) + TextWidth(std::to_string(c.num_places - 1), small) +
         TextWidth(PlotLegend(c, o), small) + 6 * kPadPx;
}

// The layout plus the note strips and the whole plot strip, which only the renderer needs.
struct Geometry {
  MatchImageLayout layout;
  cv::Rect query_note, reference_note, plot_strip;
};

Geometry ComputeGeometry(const MatchImageContent& c, const MatchImageOptions& o) {
  o.Validate();
  ValidateContent(c);
  const TextStyle label = LabelStyle(o), small = SmallStyle(o);
  const cv::Size qs = PanelSize(c.query, o), rs = PanelSize(c.reference, o);
  // Each panel's column is wide enough for its note; the gap leaves room for the frame.
  const int qcol = std::max(qs.width, c.query.empty() ? 0 : TextWidth(c.query_note, small));
  const int rcol = std::max(rs.width, c.reference.empty() ? 0 : TextWidth(c.reference_note, small));
  const int gap = 2 * kMarginPx;
  int label_w = 0;
  for (const auto& line : c.label_lines) label_w = std::max(label_w, TextWidth(line, label));
  const int inner_w = std::max({qcol + gap + rcol, label_w + 3 * kPadPx, PlotMinWidth(c, o)});
  const int width = inner_w + 2 * kMarginPx;

  Geometry g;
  const int x0 = (width - (qcol + gap + rcol)) / 2;
  const int row_h = std::max(qs.height, rs.height);
  g.layout.query = {x0 + (qcol - qs.width) / 2, kMarginPx, qs.width, qs.height};
  g.layout.reference = {x0 + qcol + gap + (rcol - rs.width) / 2, kMarginPx, rs.width, rs.height};
  const int note_y = kMarginPx + row_h + kFramePx + 2;
  g.query_note = {x0, note_y, qcol, small.line_px};
  g.reference_note = {x0 + qcol + gap, note_y, rcol, small.line_px};
  const int label_y = note_y + small.line_px + kMarginPx / 2;
  const int label_h =
      c.label_lines.empty() ? 0 : static_cast<int>(c.label_lines.size()) * label.line_px + kPadPx;
  g.layout.label = {kMarginPx, label_y, inner_w, label_h};
  g.plot_strip = {kMarginPx, label_y + label_h + kMarginPx / 2, inner_w, o.plot_height_px};
  const int header = PlotHeaderPx(small), footer = PlotFooterPx(small);
  g.layout.plot = {g.plot_strip.x + kPadPx, g.plot_strip.y + header, inner_w - 2 * kPadPx,
                   o.plot_height_px - header - footer};
  g.layout.image = {width, g.plot_strip.br().y + kMarginPx};
  return g;
}

// Splits text at spaces into lines no wider than max_w (a single long word stays whole).
std::vector<std::string> WrapWords(const std::string& text, const TextStyle& s, int max_w) {
  std::vector<std::string> lines;
  std::istringstream words(text);
  std::string word, line;
  while (words >> word) {
    const std::string longer = line.empty() ? word : line + " " + word;
    if (!line.empty() && TextWidth(longer, s) > max_w) {
      lines.push_back(line);
      line = word;
    } else {
      line = longer;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

void DrawCentredLines(cv::Mat& img, const std::vector<std::string>& lines, const cv::Rect& r,
                      const TextStyle& s, const cv::Scalar& colour) {
  const int block_h = static_cast<int>(lines.size()) * s.line_px;
  int baseline_y = r.y + (r.height - block_h) / 2 + s.ascent_px;
  for (const auto& line : lines) {
    Put(img, line, {r.x + (r.width - TextWidth(line, s)) / 2, baseline_y}, s, colour);
    baseline_y += s.line_px;
  }
}

// Scales the image into its panel: INTER_NEAREST when enlarging (thumbnails keep their
// pixels), INTER_AREA when shrinking; mono is drawn as grey. A missing image becomes a
// placeholder with its note.
void DrawPanel(cv::Mat& canvas, const cv::Mat& image, const cv::Rect& panel,
               const std::string& note, const TextStyle& s) {
  if (image.empty()) {
    canvas(panel).setTo(kPlaceholder);
    DrawCentredLines(canvas, WrapWords(note, s, panel.width - 2 * kPadPx), panel, s, kText);
    return;
  }
  cv::Mat bgr = image;
  if (image.type() == CV_8UC1) cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  const bool enlarge = panel.width >= image.cols && panel.height >= image.rows;
  cv::Mat scaled;
  cv::resize(bgr, scaled, panel.size(), 0, 0, enlarge ? cv::INTER_NEAREST : cv::INTER_AREA);
  scaled.copyTo(canvas(panel));
}

void DrawLabel(cv::Mat& canvas, const MatchImageContent& c, const cv::Rect& r, const TextStyle& s,
               const cv::Scalar& accept_colour) {
  if (c.label_lines.empty()) return;
  canvas(r).setTo(kBlock);
  int baseline_y = r.y + kPadPx / 2 + s.ascent_px + (s.line_px - s.ascent_px) / 4;
  for (size_t i = 0; i < c.label_lines.size(); ++i) {
    Put(canvas, c.label_lines[i], {r.x + 2 * kPadPx, baseline_y}, s,
        i == 0 ? accept_colour : kText);
    baseline_y += s.line_px;
  }
}

// Columns [first, last] of the data area that place p fills.
std::pair<int, int> PlaceColumns(int place, int num_places, int width) {
  const int first = static_cast<int>(static_cast<int64_t>(place) * width / num_places);
  const int end = static_cast<int>(static_cast<int64_t>(place + 1) * width / num_places);
  return {first, std::max(first, end - 1)};
}

// Bar level in [0, 1] per place_ids entry: P / max P, its log10 over kLogDecades below the
// maximum, or the rank (best = 1) when there is no posterior.
std::vector<float> PlaceLevels(const MatchImageContent& c, bool log_scale) {
  const size_t k_count = c.place_ids.size();
  std::vector<float> levels(k_count, 0.0f);
  if (c.posterior.empty()) {
    for (size_t k = 0; k < k_count; ++k) levels[k] = float(k_count - k) / float(k_count);
    return levels;
  }
  const float top = *std::max_element(c.posterior.begin(), c.posterior.end());
  if (top <= 0) return levels;
  for (size_t k = 0; k < k_count; ++k) {
    const float p = c.posterior[k];
    if (!log_scale) {
      levels[k] = p / top;
    } else if (p > 0) {
      const double decades = std::log10(double(p) / double(top)) + kLogDecades;
      levels[k] = static_cast<float>(std::clamp(decades / kLogDecades, 0.0, 1.0));
    }
  }
  return levels;
}

// Bar height (pixels) per column of the data area: the tallest place in the column, so a
// peak survives when many places share one column.
std::vector<int> ColumnHeights(const MatchImageContent& c, const MatchImageOptions& o,
                               const cv::Rect& data) {
  const std::vector<float> levels = PlaceLevels(c, o.log_scale);
  std::vector<float> column_level(data.width, 0.0f);
  for (size_t k = 0; k < levels.size(); ++k) {
    const auto [first, last] = PlaceColumns(c.place_ids[k], c.num_places, data.width);
    for (int x = first; x <= last; ++x) column_level[x] = std::max(column_level[x], levels[k]);
  }
  std::vector<int> heights(data.width);
  for (int x = 0; x < data.width; ++x) {
    heights[x] = static_cast<int>(std::lround(column_level[x] * data.height));
  }
  return heights;
}

// Columns [first, last] of a place, widened to at least min_w so a marker stays visible.
std::pair<int, int> MarkerColumns(int place, int num_places, const cv::Rect& data, int min_w) {
  auto [first, last] = PlaceColumns(place, num_places, data.width);
  const int grow = std::max(0, min_w - (last - first + 1));
  first = std::max(0, first - grow / 2);
  last = std::min(data.width - 1, last + (grow - grow / 2));
  return {data.x + first, data.x + last};
}

void DrawMatchMarker(cv::Mat& canvas, const MatchImageContent& c, const cv::Rect& data,
                     const TextStyle& s, const cv::Scalar& colour) {
  const auto [first, last] = PlaceColumns(c.match, c.num_places, data.width);
  const int x = data.x + (first + last) / 2;
  // The line lies behind the bars: it shows above a low bar, the triangle above a full one.
  cv::line(canvas, {x, data.y}, {x, data.br().y - 1}, colour, 1);
  const int half = std::max(3, s.ascent_px / 2);
  const std::vector<cv::Point> triangle = {
      {x - half, data.y - s.ascent_px - 2}, {x + half, data.y - s.ascent_px - 2}, {x, data.y - 2}};
  cv::fillConvexPoly(canvas, triangle, colour, cv::LINE_AA);
  const std::string number = std::to_string(c.match);
  const int w = TextWidth(number, s);
  const bool right = x + half + 3 + w <= data.br().x;
  Put(canvas, number, {right ? x + half + 3 : x - half - 3 - w, data.y - 3}, s, colour);
}

void DrawPlot(cv::Mat& canvas, const MatchImageContent& c, const MatchImageOptions& o,
              const Geometry& g, const cv::Scalar& accept_colour) {
  const TextStyle s = SmallStyle(o);
  const cv::Rect& data = g.layout.plot;
  canvas(g.plot_strip).setTo(kBlock);
  if (c.match >= 0) DrawMatchMarker(canvas, c, data, s, accept_colour);
  const std::vector<int> heights = ColumnHeights(c, o, data);
  for (int x = 0; x < data.width; ++x) {
    if (heights[x] <= 0) continue;
    canvas(cv::Rect(data.x + x, data.br().y - heights[x], 1, heights[x])).setTo(kBars);
  }
  const int axis_y = data.br().y;
  cv::line(canvas, {data.x, axis_y}, {data.br().x - 1, axis_y}, kAxis, 1);
  for (int place : c.true_places) {
    const auto [x0, x1] = MarkerColumns(place, c.num_places, data, 3);
    cv::rectangle(canvas, cv::Rect(x0, axis_y + 2, x1 - x0 + 1, kTickPx), kTruePlace, cv::FILLED);
  }
  const int text_y = axis_y + 5 + kTickPx + s.ascent_px;
  const std::string last = std::to_string(c.num_places - 1), legend = PlotLegend(c, o);
  Put(canvas, "0", {data.x, text_y}, s, kNoteText);
  Put(canvas, last, {data.br().x - TextWidth(last, s), text_y}, s, kNoteText);
  Put(canvas, legend, {data.x + (data.width - TextWidth(legend, s)) / 2, text_y}, s, kAxis);
}

}  // namespace

void MatchImageOptions::Validate() const {
  CheckRange("panel_height_px", panel_height_px, 16, 4096);
  CheckRange("max_panel_width_px", max_panel_width_px, 16, 16384);
  CheckRange("text_height_px", text_height_px, 6, 64);
  const TextStyle small = SmallStyle(*this);
  // At least 16 rows of bars between the marker row and the ticks.
  CheckRange("plot_height_px", plot_height_px, PlotHeaderPx(small) + PlotFooterPx(small) + 16,
             4096);
}

MatchImageLayout MatchImageLayoutFor(const MatchImageContent& content,
                                     const MatchImageOptions& options) {
  return ComputeGeometry(content, options).layout;
}

cv::Mat RenderMatchImage(const MatchImageContent& content, const MatchImageOptions& options) {
  const Geometry g = ComputeGeometry(content, options);
  const TextStyle label = LabelStyle(options), small = SmallStyle(options);
  const cv::Scalar accept_colour = content.accepted ? kAccepted : kRejected;
  cv::Mat canvas(g.layout.image, CV_8UC3, kBackground);
  const cv::Rect& ref = g.layout.reference;
  canvas(cv::Rect(ref.x - kFramePx, ref.y - kFramePx, ref.width + 2 * kFramePx,
                  ref.height + 2 * kFramePx))
      .setTo(accept_colour);
  DrawPanel(canvas, content.query, g.layout.query, content.query_note, small);
  DrawPanel(canvas, content.reference, ref, content.reference_note, small);
  if (!content.query.empty()) {
    DrawCentredLines(canvas, {content.query_note}, g.query_note, small, kNoteText);
  }
  if (!content.reference.empty()) {
    DrawCentredLines(canvas, {content.reference_note}, g.reference_note, small, kNoteText);
  }
  DrawLabel(canvas, content, g.layout.label, label, accept_colour);
  DrawPlot(canvas, content, options, g, accept_colour);
  return canvas;
}

}  // namespace bsf_vpr
