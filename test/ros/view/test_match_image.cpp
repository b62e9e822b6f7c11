// Tests of the match image by its pixels: which panel holds which image, where the plot's
// bars and markers fall, the frame colour, the text, and the refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "src/ros/view/match_image.h"

namespace bsf_vpr {
namespace {

// Smooth images that differ everywhere: the query's blue rises to the right, the
// reference's red rises downwards.
cv::Mat QueryImage(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) img.at<cv::Vec3b>(y, x) = cv::Vec3b(30 + 200 * x / w, 90, 20);
  }
  return img;
}

cv::Mat ReferenceImage(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) img.at<cv::Vec3b>(y, x) = cv::Vec3b(20, 160, 30 + 200 * y / h);
  }
  return img;
}

// 100 places, posterior peaked at place 70, matched and accepted.
MatchImageContent PeakedContent() {
  MatchImageContent c;
  c.query = QueryImage(160, 120);
  c.query_note = "query";
  c.reference = ReferenceImage(200, 100);
  c.reference_note = "summer, place 70";
  c.label_lines = {"place 70  p=0.97 (log-odds 3.4)", "ACCEPTED", "selected: summer, fall"};
  c.accepted = true;
  c.num_places = 100;
  for (int i = 0; i < 100; ++i) {
    c.place_ids.push_back(i);
    c.posterior.push_back(static_cast<float>(std::exp(-0.5 * std::pow((i - 70) / 2.0, 2))));
  }
  c.match = 70;
  return c;
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar m = cv::mean(diff);
  return (m[0] + m[1] + m[2]) / 3.0;
}

// The image as the test expects it in a panel of that size (bilinear, unlike the renderer).
cv::Mat Resized(const cv::Mat& img, const cv::Size& size) {
  cv::Mat out;
  cv::resize(img, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

using PixelTest = std::function<bool(const cv::Vec3b&)>;
// BGR colour classes, loose so that anti-aliasing and shades do not matter.
const PixelTest kIsBar = [](const cv::Vec3b& p) {
  return p[0] > 200 && p[1] > 130 && p[1] < 200 && p[2] < 110;
};
const PixelTest kIsCyan = [](const cv::Vec3b& p) { return p[0] > 220 && p[1] > 220 && p[2] < 60; };
const PixelTest kIsGreen = [](const cv::Vec3b& p) {
  return p[1] > 170 && p[0] < 110 && p[2] < 110;
};
const PixelTest kIsOrange = [](const cv::Vec3b& p) {
  return p[2] > 220 && p[1] > 100 && p[1] < 200 && p[0] < 60;
};
const PixelTest kIsBright = [](const cv::Vec3b& p) { return std::max({p[0], p[1], p[2]}) > 150; };

int Count(const cv::Mat& img, const cv::Rect& r, const PixelTest& is) {
  int n = 0;
  for (int y = r.y; y < r.br().y; ++y) {
    for (int x = r.x; x < r.br().x; ++x) n += is(img.at<cv::Vec3b>(y, x)) ? 1 : 0;
  }
  return n;
}

// Bar pixels per column of the plot's data area.
std::vector<int> BarHeights(const cv::Mat& img, const cv::Rect& plot) {
  std::vector<int> heights;
  for (int x = plot.x; x < plot.br().x; ++x) {
    heights.push_back(Count(img, cv::Rect(x, plot.y, 1, plot.height), kIsBar));
  }
  return heights;
}

// Columns (relative to plot.x) that place p fills, as the layout's contract states.
std::pair<int, int> ColumnsOf(int place, int num_places, const cv::Rect& plot) {
  const int first = static_cast<int>(static_cast<int64_t>(place) * plot.width / num_places);
  const int end = static_cast<int>(static_cast<int64_t>(place + 1) * plot.width / num_places);
  return {first, std::max(first, end - 1)};
}

int TallestColumn(const std::vector<int>& heights) {
  return static_cast<int>(std::max_element(heights.begin(), heights.end()) - heights.begin());
}

int MaxHeightOfPlace(const std::vector<int>& heights, int place, int n, const cv::Rect& plot) {
  const auto [first, last] = ColumnsOf(place, n, plot);
  return *std::max_element(heights.begin() + first, heights.begin() + last + 1);
}

TEST(MatchImage, ImageHasTheLayoutSizeAndPartsInside) {
  const MatchImageContent c = PeakedContent();
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  EXPECT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(img.size(), l.image);
  const cv::Rect whole(cv::Point(0, 0), l.image);
  for (const cv::Rect& r : {l.query, l.reference, l.label, l.plot}) {
    EXPECT_EQ(r & whole, r) << r;
    EXPECT_GT(r.area(), 0) << r;
  }
  EXPECT_EQ(l.query.height, 240);
  EXPECT_EQ(l.reference.height, 240);
  EXPECT_EQ(l.query.width, 320);      // 160x120 at 4:3
  EXPECT_EQ(l.reference.width, 480);  // 200x100 at 2:1
  EXPECT_LT(l.query.br().x, l.reference.x);
  EXPECT_LT(l.reference.br().y, l.label.y);
  EXPECT_LT(l.label.br().y, l.plot.y);
}

// Enlarged thumbnails (Nordland 64x32), shrunk large images and odd sizes all land in their
// panels.
class PanelsHoldTheirImages : public ::testing::TestWithParam<cv::Size> {};

TEST_P(PanelsHoldTheirImages, QueryLeftReferenceRight) {
  MatchImageContent c = PeakedContent();
  c.query = QueryImage(GetParam().width, GetParam().height);
  c.reference = ReferenceImage(GetParam().width, GetParam().height);
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  EXPECT_LT(MeanAbsDiff(img(l.query), Resized(c.query, l.query.size())), 6.0);
  EXPECT_LT(MeanAbsDiff(img(l.reference), Resized(c.reference, l.reference.size())), 6.0);
  EXPECT_GT(MeanAbsDiff(img(l.query), Resized(c.reference, l.query.size())), 40.0);

  // Swapped content: the panels swap too.
  std::swap(c.query, c.reference);
  const cv::Mat swapped = RenderMatchImage(c, MatchImageOptions());
  EXPECT_LT(MeanAbsDiff(swapped(l.query), Resized(c.query, l.query.size())), 6.0);
  EXPECT_GT(MeanAbsDiff(swapped(l.query), img(l.query)), 40.0);
  EXPECT_GT(MeanAbsDiff(swapped(l.reference), img(l.reference)), 40.0);
}

INSTANTIATE_TEST_SUITE_P(Sizes, PanelsHoldTheirImages,
                         ::testing::Values(cv::Size(64, 32), cv::Size(640, 360), cv::Size(256, 144),
                                           cv::Size(97, 61)));

TEST(MatchImage, MonoImageIsDrawnAsGrey) {
  MatchImageContent c = PeakedContent();
  cv::Mat mono(50, 80, CV_8UC1);
  for (int y = 0; y < mono.rows; ++y) {
    for (int x = 0; x < mono.cols; ++x) mono.at<uint8_t>(y, x) = static_cast<uint8_t>(3 * x);
  }
  c.query = mono;
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  cv::Mat bgr;
  cv::cvtColor(mono, bgr, cv::COLOR_GRAY2BGR);
  EXPECT_LT(
      MeanAbsDiff(RenderMatchImage(c, MatchImageOptions())(l.query), Resized(bgr, l.query.size())),
      6.0);
}

// Vertical black/white stripes one pixel wide.
cv::Mat Stripes(int w, int h) {
  cv::Mat img(h, w, CV_8UC3);
  for (int x = 0; x < w; ++x) img.col(x).setTo(cv::Scalar::all(x % 2 ? 255 : 0));
  return img;
}

// Thumbnails are enlarged without blending neighbours; large images are shrunk by averaging,
// not by dropping pixels (which would alias the stripes into solid black or white).
TEST(MatchImage, ThumbnailsStayCrispAndLargeImagesAreAveraged) {
  MatchImageContent c = PeakedContent();
  c.query = Stripes(64, 32);
  c.reference = Stripes(720, 360);
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  ASSERT_EQ(l.reference.size(), cv::Size(480, 240));
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  const auto is_black_or_white = [](const cv::Vec3b& p) { return p[0] == 0 || p[0] == 255; };
  EXPECT_EQ(Count(img, l.query, is_black_or_white), l.query.area());
  cv::Scalar mean, stddev;
  cv::meanStdDev(img(l.reference), mean, stddev);
  EXPECT_NEAR(mean[0], 127.5, 5.0);
  EXPECT_LT(stddev[0], 60.0);
}

TEST(MatchImage, ImageWiderThanTheCapIsShrunkToIt) {
  MatchImageContent c = PeakedContent();
  c.reference = ReferenceImage(1000, 50);
  MatchImageOptions o;
  o.max_panel_width_px = 600;
  const MatchImageLayout l = MatchImageLayoutFor(c, o);
  EXPECT_EQ(l.reference.size(), cv::Size(600, 30));
  EXPECT_LT(MeanAbsDiff(RenderMatchImage(c, o)(l.reference), Resized(c.reference, {600, 30})), 6.0);
}

TEST(MatchImage, TallestBarIsAtTheMatchedPlace) {
  const MatchImageContent c = PeakedContent();
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const std::vector<int> h = BarHeights(RenderMatchImage(c, MatchImageOptions()), l.plot);
  const auto [first, last] = ColumnsOf(70, 100, l.plot);
  EXPECT_GE(TallestColumn(h), first);
  EXPECT_LE(TallestColumn(h), last);
  EXPECT_GE(h[TallestColumn(h)], l.plot.height - 1);
  EXPECT_EQ(MaxHeightOfPlace(h, 20, 100, l.plot), 0);
}

TEST(MatchImage, TopKPosteriorPutsItsBarsAtItsPlaces) {
  MatchImageContent c = PeakedContent();
  c.place_ids = {70, 69, 71, 10, 90};
  c.posterior = {0.6f, 0.15f, 0.15f, 0.05f, 0.05f};
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const std::vector<int> h = BarHeights(RenderMatchImage(c, MatchImageOptions()), l.plot);
  const auto [first, last] = ColumnsOf(70, 100, l.plot);
  EXPECT_GE(TallestColumn(h), first);
  EXPECT_LE(TallestColumn(h), last);
  EXPECT_NEAR(MaxHeightOfPlace(h, 10, 100, l.plot), l.plot.height / 12.0, 2.0);
  EXPECT_EQ(MaxHeightOfPlace(h, 50, 100, l.plot), 0);
}

// 20000 places share the columns: a one-place spike must stand taller than a broad half-high
// bump (a column mean would flatten the spike below the bump).
TEST(MatchImage, ColumnShowsTheMaximumOfItsPlaces) {
  MatchImageContent c = PeakedContent();
  c.num_places = 20000;
  c.place_ids.clear();
  c.posterior.clear();
  for (int i = 0; i < c.num_places; ++i) {
    c.place_ids.push_back(i);
    c.posterior.push_back(i == 14000 ? 1.0f : (i >= 4000 && i < 4200 ? 0.5f : 0.001f));
  }
  c.match = 14000;
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  ASSERT_LT(l.plot.width, 2000);  // several places per column
  const std::vector<int> h = BarHeights(RenderMatchImage(c, MatchImageOptions()), l.plot);
  EXPECT_EQ(TallestColumn(h), ColumnsOf(14000, c.num_places, l.plot).first);
  EXPECT_NEAR(MaxHeightOfPlace(h, 4100, c.num_places, l.plot), l.plot.height / 2.0, 1.0);
}

TEST(MatchImage, LogScaleShowsASmallSecondPeakThatLinearHides) {
  MatchImageContent c = PeakedContent();
  c.place_ids = {30, 80, 50};
  c.posterior = {1.0f, 1e-3f, 1e-9f};  // 50 lies below the kLogDecades decades: no bar either way
  c.match = 30;
  MatchImageOptions o;
  const MatchImageLayout l = MatchImageLayoutFor(c, o);
  const std::vector<int> linear = BarHeights(RenderMatchImage(c, o), l.plot);
  o.log_scale = true;
  const std::vector<int> log = BarHeights(RenderMatchImage(c, o), l.plot);
  EXPECT_EQ(MaxHeightOfPlace(linear, 80, 100, l.plot), 0);
  EXPECT_NEAR(MaxHeightOfPlace(log, 80, 100, l.plot), l.plot.height * (1 - 3 / kLogDecades), 1.0);
  EXPECT_EQ(MaxHeightOfPlace(log, 50, 100, l.plot), 0);
  EXPECT_GE(MaxHeightOfPlace(log, 30, 100, l.plot), l.plot.height - 1);
}

TEST(MatchImage, DistanceMethodShowsTheBestRankTallest) {
  MatchImageContent c = PeakedContent();
  c.posterior.clear();
  c.place_ids = {40, 10, 90};
  c.match = 40;
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const std::vector<int> h = BarHeights(RenderMatchImage(c, MatchImageOptions()), l.plot);
  const int h40 = MaxHeightOfPlace(h, 40, 100, l.plot), h10 = MaxHeightOfPlace(h, 10, 100, l.plot),
            h90 = MaxHeightOfPlace(h, 90, 100, l.plot);
  EXPECT_GT(h40, h10);
  EXPECT_GT(h10, h90);
  EXPECT_GT(h90, 0);
  EXPECT_EQ(MaxHeightOfPlace(h, 70, 100, l.plot), 0);
}

// The match line lies behind the bars: where the matched place's bar is low, it shows.
TEST(MatchImage, MatchIsAVerticalLineInTheAcceptColour) {
  MatchImageContent c = PeakedContent();
  c.match = 20;
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  const auto [first, last] = ColumnsOf(20, 100, l.plot);
  const cv::Rect at_match(l.plot.x + first, l.plot.y, last - first + 1, l.plot.height);
  EXPECT_GE(Count(img, at_match, kIsGreen), l.plot.height - 2);
  const auto [first60, last60] = ColumnsOf(60, 100, l.plot);
  const int below_label = l.label.br().y;
  EXPECT_EQ(
      Count(img,
            cv::Rect(l.plot.x + first60, below_label, last60 - first60 + 1, img.rows - below_label),
            kIsGreen),
      0);
}

TEST(MatchImage, TruePlaceTickAppearsUnderItsPlaceOnly) {
  MatchImageContent c = PeakedContent();
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const cv::Rect below(0, l.plot.br().y, l.image.width, l.image.height - l.plot.br().y);
  EXPECT_EQ(Count(RenderMatchImage(c, MatchImageOptions()), cv::Rect({0, 0}, l.image), kIsCyan), 0);

  c.true_places = {40};
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  const auto [first, last] = ColumnsOf(40, 100, l.plot);
  EXPECT_GT(
      Count(img, cv::Rect(l.plot.x + first, below.y, last - first + 1, below.height), kIsCyan), 10);
  const auto [first70, last70] = ColumnsOf(70, 100, l.plot);
  EXPECT_EQ(Count(img, cv::Rect(l.plot.x + first70, 0, last70 - first70 + 1, img.rows), kIsCyan),
            0);
}

TEST(MatchImage, FrameIsGreenWhenAcceptedAndOrangeWhenNot) {
  MatchImageContent c = PeakedContent();
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  const cv::Rect& r = l.reference;
  // Two-pixel-thick strips just outside the reference panel, on all four sides.
  const std::vector<cv::Rect> ring = {{r.x - 2, r.y, 2, r.height},
                                      {r.br().x, r.y, 2, r.height},
                                      {r.x, r.y - 2, r.width, 2},
                                      {r.x, r.br().y, r.width, 2}};
  const cv::Mat accepted = RenderMatchImage(c, MatchImageOptions());
  c.accepted = false;
  const cv::Mat rejected = RenderMatchImage(c, MatchImageOptions());
  for (const cv::Rect& side : ring) {
    EXPECT_EQ(Count(accepted, side, kIsGreen), side.area()) << side;
    EXPECT_EQ(Count(rejected, side, kIsOrange), side.area()) << side;
  }
  const cv::Rect left_of_query(l.query.x - 2, l.query.y, 2, l.query.height);
  EXPECT_EQ(Count(accepted, left_of_query, kIsGreen), 0);
}

TEST(MatchImage, MissingQueryBecomesAPlaceholderWithItsNote) {
  MatchImageContent c = PeakedContent();
  const cv::Mat query = c.query;
  c.query = cv::Mat();
  c.query_note = "no query image";
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  EXPECT_EQ(l.query.size(), cv::Size(320, 240));
  const cv::Mat img = RenderMatchImage(c, MatchImageOptions());
  EXPECT_GT(MeanAbsDiff(img(l.query), Resized(query, l.query.size())), 40.0);
  const int text = Count(img, l.query, kIsBright);
  EXPECT_GT(text, 100);
  EXPECT_LT(text, l.query.area() / 10);
  // Only the text's rows hold bright pixels; the panel is grey elsewhere.
  EXPECT_EQ(Count(img, cv::Rect(l.query.x, l.query.y, l.query.width, 80), kIsBright), 0);
}

// Rows of the rect that hold bright pixels, grouped into runs separated by blank rows.
int TextLineCount(const cv::Mat& img, const cv::Rect& r) {
  int runs = 0;
  bool in_run = false;
  for (int y = r.y; y < r.br().y; ++y) {
    const bool bright = Count(img, cv::Rect(r.x, y, r.width, 1), kIsBright) > 0;
    runs += (bright && !in_run) ? 1 : 0;
    in_run = bright;
  }
  return runs;
}

TEST(MatchImage, LabelBlockHoldsOneTextLinePerLabelLine) {
  MatchImageContent c = PeakedContent();
  const MatchImageLayout l = MatchImageLayoutFor(c, MatchImageOptions());
  EXPECT_EQ(TextLineCount(RenderMatchImage(c, MatchImageOptions()), l.label), 3);
  c.label_lines.push_back("fourth line");
  const MatchImageLayout l4 = MatchImageLayoutFor(c, MatchImageOptions());
  EXPECT_EQ(TextLineCount(RenderMatchImage(c, MatchImageOptions()), l4.label), 4);
}

TEST(MatchImage, ImageIsWideEnoughForTheLongestLabelLine) {
  MatchImageContent c = PeakedContent();
  c.query = QueryImage(64, 32);
  c.reference = ReferenceImage(64, 32);
  const std::string long_line(150, 'W');
  c.label_lines = {"short", long_line, "also short"};
  MatchImageOptions o;
  o.panel_height_px = 32;
  const MatchImageLayout l = MatchImageLayoutFor(c, o);
  const cv::Mat img = RenderMatchImage(c, o);
  int baseline = 0;
  const double scale = cv::getFontScaleFromHeight(cv::FONT_HERSHEY_SIMPLEX, o.text_height_px);
  EXPECT_GT(img.cols,
            cv::getTextSize(long_line, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width);
  // The text ends inside the image with a margin: it is not clipped at the edge.
  int rightmost = -1;
  for (int x = 0; x < img.cols; ++x) {
    if (Count(img, cv::Rect(x, l.label.y, 1, l.label.height), kIsBright) > 0) rightmost = x;
  }
  EXPECT_GT(rightmost, img.cols / 2);
  EXPECT_LT(rightmost, img.cols - 4);
}

template <typename F>
void ExpectRefusal(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one naming " << needle;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

void ExpectContentRefused(const MatchImageContent& c, const std::string& needle) {
  ExpectRefusal([&] { RenderMatchImage(c, MatchImageOptions()); }, needle);
  ExpectRefusal([&] { MatchImageLayoutFor(c, MatchImageOptions()); }, needle);
}

TEST(MatchImage, RefusesBadContentNamingTheProblem) {
  MatchImageContent c = PeakedContent();
  c.place_ids[3] = 100;
  ExpectContentRefused(c, "place_ids[3] = 100");
  c = PeakedContent();
  c.place_ids[5] = -1;
  ExpectContentRefused(c, "place_ids[5] = -1");
  c = PeakedContent();
  c.posterior.resize(2);
  ExpectContentRefused(c, "posterior has 2 entries but place_ids 100");
  c = PeakedContent();
  c.posterior[7] = std::nanf("");
  ExpectContentRefused(c, "posterior[7]");
  c = PeakedContent();
  c.posterior[8] = -0.5f;
  ExpectContentRefused(c, "posterior[8]");
  c = PeakedContent();
  c.num_places = 0;
  ExpectContentRefused(c, "num_places must be >= 1, got 0");
  c = PeakedContent();
  c.match = 100;
  ExpectContentRefused(c, "match = 100");
  c = PeakedContent();
  c.true_places = {5, 250};
  ExpectContentRefused(c, "true_places[1] = 250");
  c = PeakedContent();
  c.query = cv::Mat(10, 10, CV_32FC3, cv::Scalar::all(0));
  ExpectContentRefused(c, "query must be CV_8UC3 or CV_8UC1, got CV_32FC3");
  c = PeakedContent();
  c.reference = cv::Mat(10, 10, CV_8UC4, cv::Scalar::all(0));
  ExpectContentRefused(c, "reference must be CV_8UC3 or CV_8UC1, got CV_8UC4");
}

TEST(MatchImage, RefusesBadOptionsNamingTheField) {
  const auto refused = [](const std::function<void(MatchImageOptions&)>& change,
                          const std::string& field) {
    MatchImageOptions o;
    change(o);
    ExpectRefusal([&] { o.Validate(); }, "MatchImageOptions." + field);
    ExpectRefusal([&] { RenderMatchImage(PeakedContent(), o); }, "MatchImageOptions." + field);
  };
  refused([](MatchImageOptions& o) { o.panel_height_px = 0; }, "panel_height_px");
  refused([](MatchImageOptions& o) { o.panel_height_px = 100000; }, "panel_height_px");
  refused([](MatchImageOptions& o) { o.max_panel_width_px = 5; }, "max_panel_width_px");
  refused([](MatchImageOptions& o) { o.plot_height_px = 20; }, "plot_height_px");
  refused([](MatchImageOptions& o) { o.text_height_px = 2; }, "text_height_px");
  EXPECT_NO_THROW(MatchImageOptions().Validate());
}

}  // namespace
}  // namespace bsf_vpr
