// bsf_make_views: a traversal's images as a camera turned sideways would see them (a crop of
// each frame moved left or right), to test fusion across viewpoints from real frames, or
// as a blind camera would give them (covered, grey, black, dazzled), to test that nothing is
// then accepted (see --help).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "src/tools/common/cli_util.h"

namespace {

const char kUsage[] = R"(usage: bsf_make_views --images DIR --out DIR [--crop F] [--shift S]
                      [--blind covered|grey|black|dazzled] [--cover true]

Writes each image of DIR (.png, .jpg, .jpeg, .ppm, .bmp; sorted by name) to the folder
--out as <name>.png, cropped to the fraction F of its width and height (centred
vertically) with the crop's centre moved S widths to the right of the frame's centre (S < 0:
to the left). The same crop of every frame is the view of a camera turned sideways by about
S times its horizontal field of view; frames of one traversal made with different S are the
traversal from different viewpoints (docs/results.md, Study 7).
  --crop F    fraction of the width and height kept, in (0, 1] (default 0.7)
  --shift S   the crop's offset from the centre, in frame widths; |S| <= (1 - F) / 2
              (default 0)
  --blind K   the view of a blind camera, given a sensor's noise (Gaussian, sigma 2 grey
              levels; the same seed every run), rounded and saturated to 0..255. No place
              shows in it (docs/results.md, Study 8). K is one of
                covered: through a covered lens (a hand, a lens cap that lets some light
                  through, mud): blurred (Gaussian, sigma a quarter of the view's width:
                  only the light's slow gradient is left), darkened to 5%
                grey: uniform grey (128), as a fogged or defocused lens on a flat field
                black: no light at all (the noise half cut off at 0)
                dazzled: the sun in the lens: 98% of the way to white
  --cover true  the same as --blind covered (false: no effect)
  -h, --help  this help
Exit status 2 with one line naming the problem on bad arguments or an unreadable image.
)";

// What a blind camera of kind `blind` (--blind) shows instead of `view`.
cv::Mat BlindView(const cv::Mat& view, const std::string& blind, cv::RNG* noise) {
  cv::Mat light(view.size(), CV_32FC3, cv::Scalar::all(0));  // grey levels before the noise
  if (blind == "covered") {
    cv::Mat blurred;
    cv::GaussianBlur(view, blurred, cv::Size(0, 0), std::max(1.0, view.cols / 4.0));
    blurred.convertTo(light, CV_32FC3, 0.05);
  } else if (blind == "grey") {
    light.setTo(cv::Scalar::all(128));
  } else if (blind == "dazzled") {
    view.convertTo(light, CV_32FC3, 0.02, 0.98 * 255);
  }
  cv::Mat sensor(view.size(), CV_32FC3), out;
  noise->fill(sensor, cv::RNG::NORMAL, 0.0, 2.0);
  cv::Mat(light + sensor).convertTo(out, CV_8UC3);  // rounded, saturated to 0..255
  return out;
}

int Run(int argc, char** argv) {
  namespace fs = std::filesystem;
  using namespace bsf_vpr;
  std::string images, out;
  double crop = 0.7, shift = 0;
  std::string blind;  // "": the view itself
  tools::FlagReader flags(argc, argv);
  for (std::string f, v; flags.Next(&f, &v);) {
    if (f == "--images")
      images = v;
    else if (f == "--out")
      out = v;
    else if (f == "--crop")
      crop = tools::ParseNumber(f, v);
    else if (f == "--shift")
      shift = tools::ParseNumber(f, v);
    else if (f == "--blind" && (v == "covered" || v == "grey" || v == "black" || v == "dazzled"))
      blind = v;
    else if (f == "--blind")
      throw std::invalid_argument("--blind takes covered, grey, black or dazzled, got '" + v + "'");
    else if (f == "--cover" && (v == "true" || v == "false"))
      blind = v == "true" ? "covered" : blind;  // false leaves a --blind as it is
    else if (f == "--cover")
      throw std::invalid_argument("--cover takes true or false, got '" + v + "'");
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (flags.help()) {
    std::cout << kUsage;
    return 0;
  }
  if (images.empty() || out.empty()) throw std::invalid_argument("--images and --out are required");
  if (!(crop > 0 && crop <= 1)) {
    throw std::invalid_argument("--crop must be in (0, 1], got " + std::to_string(crop));
  }
  if (!(std::abs(shift) <= (1 - crop) / 2 + 1e-12)) {
    throw std::invalid_argument("--shift " + std::to_string(shift) +
                                " moves the crop out of the frame: |shift| <= (1 - crop) / 2 = " +
                                std::to_string((1 - crop) / 2));
  }
  if (!fs::is_directory(images)) throw std::invalid_argument("no folder '" + images + "'");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(images)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".ppm" || ext == ".bmp")
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) throw std::invalid_argument("no images in '" + images + "'");
  fs::create_directories(out);
  cv::RNG noise(12345);
  for (const fs::path& file : files) {
    const cv::Mat frame = cv::imread(file.string(), cv::IMREAD_COLOR);
    if (frame.empty()) throw std::invalid_argument("cannot read image '" + file.string() + "'");
    const double w = crop * frame.cols, h = crop * frame.rows;
    const double x0 = (frame.cols - w) / 2 + shift * frame.cols, y0 = (frame.rows - h) / 2;
    const int left = static_cast<int>(std::lround(x0)), top = static_cast<int>(std::lround(y0));
    const int right = std::min(frame.cols, static_cast<int>(std::lround(x0 + w)));
    const int bottom = std::min(frame.rows, static_cast<int>(std::lround(y0 + h)));
    const cv::Rect roi(std::max(0, left), std::max(0, top), right - std::max(0, left),
                       bottom - std::max(0, top));
    cv::Mat view = frame(roi);
    if (!blind.empty()) view = BlindView(view, blind, &noise);
    const std::string to = (fs::path(out) / file.stem()).string() + ".png";
    if (!cv::imwrite(to, view)) throw std::runtime_error("cannot write '" + to + "'");
  }
  std::cout << "bsf_make_views: wrote " << files.size() << " views to " << out << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_make_views", Run, argc, argv);
}
