#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "bsf_vpr/core/reference_set.h"
#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/npy.h"

namespace bsf_vpr {
namespace {

const std::string kModels = std::string(BSF_SOURCE_DIR) + "/test/data/models/";
const std::string kNordland = std::string(BSF_SOURCE_DIR) + "/data/nordland_64x32/";

// Reads a serialised ONNX TensorProto (dims: field 1, data_type: field 2 = FLOAT,
// raw_data: field 9, little-endian float32) into an N-d float cv::Mat.
cv::Mat ReadTensorProto(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string b = ss.str();
  size_t i = 0;
  auto varint = [&]() {
    uint64_t v = 0;
    for (int shift = 0; i < b.size(); shift += 7) {
      const uint8_t byte = static_cast<uint8_t>(b[i++]);
      v |= static_cast<uint64_t>(byte & 0x7f) << shift;
      if (!(byte & 0x80)) break;
    }
    return v;
  };
  std::vector<int> dims;
  std::string raw;
  while (i < b.size()) {
    const uint64_t key = varint();
    const int field = static_cast<int>(key >> 3), wire = static_cast<int>(key & 7);
    if (wire == 0) {
      const uint64_t v = varint();
      if (field == 1) dims.push_back(static_cast<int>(v));
    } else if (wire == 2) {
      const size_t len = varint();
      if (field == 1) {  // packed dims
        const size_t end = i + len;
        while (i < end) dims.push_back(static_cast<int>(varint()));
      } else {
        if (field == 9) raw = b.substr(i, len);
        i += len;
      }
    } else if (wire == 5) {
      i += 4;
    } else if (wire == 1) {
      i += 8;
    } else {
      throw std::runtime_error("unexpected wire type in " + path);
    }
  }
  cv::Mat m(static_cast<int>(dims.size()), dims.data(), CV_32F);
  if (raw.size() != m.total() * 4) throw std::runtime_error("size mismatch in " + path);
  std::memcpy(m.ptr<float>(), raw.data(), raw.size());
  return m;
}

TEST(Onnx, ConvAndMaxPoolReproduceTheirReferenceOutputs) {
  for (const std::string model : {"conv2d", "maxpool2d"}) {
    const cv::Mat input = ReadTensorProto(kModels + model + "/input_0.pb");
    const cv::Mat expected = ReadTensorProto(kModels + model + "/output_0.pb");
    const cv::Mat got = RunOnnxTensor(kModels + model + "/model.onnx", input);
    ASSERT_EQ(got.total(), expected.total()) << model;
    for (int d = 0; d < expected.dims; ++d) EXPECT_EQ(got.size[d], expected.size[d]) << model;
    const cv::Mat g = got.reshape(1, 1), e = expected.reshape(1, 1);
    EXPECT_LT(cv::norm(g, e, cv::NORM_INF), 1e-4) << model;
  }
}

TEST(Onnx, CnnsDescribeRealImagesThroughThePreprocessingPath) {
  const cv::Mat img = cv::imread(kNordland + "summer/images-01000.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  for (const std::string model : {"resnet50_light", "squeezenet_light"}) {
    ImageDescriberOptions o;
    o.kind = ImageDescriberKind::kOnnx;
    o.onnx.model_path = kModels + model + "/model.onnx";
    const auto d = MakeImageDescriber(o);
    EXPECT_EQ(d->dimension(), 1000) << model;  // [1,1000] and [1,1000,1,1] both flatten
    const Eigen::VectorXf v = d->Describe(img);
    ASSERT_EQ(v.size(), 1000);
    EXPECT_TRUE(v.allFinite());
    EXPECT_NEAR(v.norm(), 1.0f, 1e-4f);
    EXPECT_EQ(d->descriptor_type(), "onnx_model_1000");  // named after the file
  }
}

TEST(Onnx, PcaProjectsTheNetworkOutput) {
  ImageDescriberOptions o;
  o.kind = ImageDescriberKind::kOnnx;
  o.onnx.model_path = kModels + "maxpool2d/model.onnx";
  o.onnx.input_width_px = o.onnx.input_height_px = 7;
  o.onnx.l2_normalize = false;
  const cv::Mat img = cv::imread(kNordland + "winter/images-02000.png", cv::IMREAD_COLOR);
  const Eigen::VectorXf raw = MakeImageDescriber(o)->Describe(img);
  ASSERT_EQ(raw.size(), 3 * 4 * 4);
  char tmpl[] = "/tmp/bsf_pca_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  RowMatrixXf pca = RowMatrixXf::Random(10, 48);
  WriteNpyMatrix(dir + "/pca.npy", pca);
  o.onnx.pca_path = dir + "/pca.npy";
  const auto projected = MakeImageDescriber(o);
  EXPECT_EQ(projected->dimension(), 10);
  EXPECT_TRUE(projected->Describe(img).isApprox(pca * raw, 1e-4f));
  WriteNpyMatrix(dir + "/bad.npy", RowMatrixXf::Random(10, 47));
  o.onnx.pca_path = dir + "/bad.npy";
  try {
    MakeImageDescriber(o);
    ADD_FAILURE() << "a PCA of the wrong width was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("10 x 47"), std::string::npos) << e.what();
  }
  std::remove((dir + "/pca.npy").c_str());
  std::remove((dir + "/bad.npy").c_str());
  rmdir(dir.c_str());
}

TEST(Onnx, AMissingOrBrokenModelFailsAtStartUpNamingTheFile) {
  ImageDescriberOptions o;
  o.kind = ImageDescriberKind::kOnnx;
  o.onnx.model_path = "/nonexistent/netvlad.onnx";
  try {
    MakeImageDescriber(o);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/netvlad.onnx"), std::string::npos);
  }
  o.onnx.model_path = kModels + "README.md";  // not a model
  try {
    MakeImageDescriber(o);
    ADD_FAILURE();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("README.md"), std::string::npos) << e.what();
  }
  o.onnx.model_path = kModels + "conv2d/model.onnx";
  o.onnx.mean = {0.5f};
  EXPECT_THROW(MakeImageDescriber(o), std::invalid_argument);
  EXPECT_THROW(ParseImageDescriberKind("netvlad"), std::invalid_argument);
  for (const char* name : {"patchnorm", "hog", "onnx"}) {
    EXPECT_EQ(ToString(ParseImageDescriberKind(name)), name);
  }
}

TEST(Hog, DescribesImagesWithTheDocumentedDimension) {
  ImageDescriberOptions o;
  o.kind = ImageDescriberKind::kHog;
  const auto d = MakeImageDescriber(o);
  EXPECT_EQ(d->dimension(), 7 * 3 * 36);
  const cv::Mat img = cv::imread(kNordland + "summer/images-01000.png", cv::IMREAD_COLOR);
  const Eigen::VectorXf v = d->Describe(img);
  ASSERT_EQ(v.size(), d->dimension());
  EXPECT_TRUE(v.allFinite());
  EXPECT_GT(v.norm(), 0);
  EXPECT_EQ(d->Describe(cv::Mat::zeros(32, 64, CV_8UC1)).norm(), 0.0f);  // no gradients
  o.hog.cell_px = 7;
  EXPECT_THROW(MakeImageDescriber(o), std::invalid_argument);
  EXPECT_EQ(d->descriptor_type(), "hog_64x32_c8_b9");
}

TEST(Describers, AUniformImageIsSaidToShowNothingAndItsDescriptorIsNoQuery) {
  const cv::Mat nordland = cv::imread(kNordland + "summer/images-01000.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(nordland.empty());
  EXPECT_EQ(BlindImageProblem(nordland), "");
  // One pixel that differs is not a scene: no longer uniform, but only noise.
  cv::Mat one_pixel = cv::Mat::zeros(480, 640, CV_8UC3);
  one_pixel.at<cv::Vec3b>(479, 639) = cv::Vec3b(255, 255, 255);
  EXPECT_NE(BlindImageProblem(one_pixel).find("only noise"), std::string::npos);
  cv::Mat small = cv::Mat::zeros(15, 31, CV_8UC1);  // too small to measure: seen
  small.at<uchar>(1, 1) = 200;
  EXPECT_EQ(BlindImageProblem(small), "");
  for (const cv::Mat& uniform :
       {cv::Mat(cv::Mat::zeros(32, 64, CV_8UC1)), cv::Mat(480, 640, CV_8UC3, cv::Scalar(90, 20, 7)),
        cv::Mat(1, 1, CV_8UC3, cv::Scalar(200, 10, 10)), cv::Mat(1, 1, CV_8UC4, cv::Scalar::all(3)),
        cv::Mat(nordland, cv::Rect(0, 0, 1, 1))}) {
    const std::string why = BlindImageProblem(uniform);
    EXPECT_NE(why.find("uniform"), std::string::npos) << uniform.size << ": " << why;
    // What the patch-normalised descriptor and HOG make of it is refused as a query.
    for (const ImageDescriberKind kind :
         {ImageDescriberKind::kPatchNorm, ImageDescriberKind::kHog}) {
      ImageDescriberOptions o;
      o.kind = kind;
      const auto describer = MakeImageDescriber(o);
      ReferenceSets map;
      map.Add(MakeReferenceSet("r", RowMatrixXf::Ones(2, describer->dimension())));
      const Eigen::VectorXf d = describer->Describe(uniform);
      EXPECT_THROW(map.CheckQuery(d), std::invalid_argument) << ToString(kind);
    }
  }
}

// Blind frames made from real ones (the repository's Nordland-100 frames, 64 x 32 and
// 256 x 144, three seasons): a covered lens (1% of the light, blurred until nothing of the
// scene survives, sensor noise), uniform grey and black with noise, a dazzled camera (98% of
// the way to white). Every one is blind; every real frame is seen, with a margin (printed:
// the least coarser / structure and scene contrast of the real frames, the most scene
// contrast of the blind ones).
TEST(Describers, BlindFramesMadeFromRealOnesAreSaidToShowOnlyNoiseAndRealFramesAreNot) {
  const std::string root = std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/";
  cv::RNG rng(7);
  const auto noisy = [&rng](const cv::Mat& mean, double sigma) {
    cv::Mat noise(mean.size(), CV_32FC3), out;
    rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar::all(sigma));
    cv::Mat m;
    mean.convertTo(m, CV_32FC3);
    cv::Mat(m + noise).convertTo(out, CV_8UC3);  // rounds and saturates, as a sensor does
    return out;
  };
  const auto ratio = [](const BlindImageMeasure& m) { return m.coarser / m.structure; };
  for (const std::string size : {"64x32", "256x144"}) {
    double least_real = 1e9, least_real_scene = 1e9, most_blind_scene = 0;
    int frames = 0;
    for (const std::string season : {"summer", "fall", "winter"}) {
      for (int i = 0; i < 100; i += 3) {
        char name[16];
        std::snprintf(name, sizeof(name), "/%03d.%s", i, size == "64x32" ? "png" : "jpg");
        const cv::Mat real = cv::imread(root + size + "/" + season + name, cv::IMREAD_COLOR);
        ASSERT_FALSE(real.empty()) << root + size + "/" + season + name;
        ++frames;
        const std::optional<BlindImageMeasure> seen = MeasureBlindImage(real);
        ASSERT_TRUE(seen);
        least_real = std::min(least_real, ratio(*seen));
        least_real_scene = std::min(least_real_scene, seen->scene());
        EXPECT_EQ(BlindImageProblem(real), "") << season << name;
        cv::Mat dim, covered;
        real.convertTo(dim, CV_32FC3, 0.01);
        cv::GaussianBlur(dim, covered, cv::Size(0, 0), real.cols / 8.0);
        cv::Mat white(real.size(), CV_32FC3, cv::Scalar::all(255)), dazzled;
        cv::Mat real_f;
        real.convertTo(real_f, CV_32FC3);
        dazzled = white - (white - real_f) * 0.02;
        const cv::Mat blind[] = {
            noisy(covered, 2), noisy(cv::Mat(real.size(), CV_32FC3, cv::Scalar::all(128)), 3),
            noisy(cv::Mat::zeros(real.size(), CV_32FC3), 3), noisy(dazzled, 2)};
        for (const cv::Mat& b : blind) {
          const std::optional<BlindImageMeasure> m = MeasureBlindImage(b);
          ASSERT_TRUE(m);
          most_blind_scene = std::max(most_blind_scene, m->scene());
          EXPECT_NE(BlindImageProblem(b).find("shows only noise"), std::string::npos)
              << size << " " << season << name << " kind " << (&b - blind) << ": structure "
              << m->structure << ", coarser " << m->coarser;
        }
      }
    }
    std::printf(
        "%s: %d real frames, least coarser / structure %.2f, least scene contrast %.1f "
        "grey levels; blind frames' scene contrast at most %.2f\n",
        size.c_str(), frames, least_real, least_real_scene, most_blind_scene);
    EXPECT_GT(least_real, 1.0) << size;
    EXPECT_GT(least_real_scene, 4.0) << size;
  }
}

// A camera's noise is rarely independent from pixel to pixel: demosaicing spreads it over
// neighbours and JPEG (a compressed image transport) keeps only its coarse part. A covered
// lens through both, at gains from clean to noisy, is still blind; the real frame seen.
TEST(Describers, ACoveredCameraWhoseNoiseIsDemosaicedAndCompressedIsBlind) {
  const cv::Mat real =
      cv::imread(std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/256x144/fall/010.jpg",
                 cv::IMREAD_COLOR);
  ASSERT_FALSE(real.empty());
  cv::Mat big, grey;
  cv::resize(real, big, cv::Size(640, 360), 0, 0, cv::INTER_LINEAR);
  cv::cvtColor(big, grey, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(BlindImageProblem(big), "");
  cv::RNG rng(9);
  for (double sigma : {2.0, 5.0, 8.0}) {
    for (int quality : {95, 80, 50}) {
      for (double light : {0.01, 0.05}) {
        cv::Mat dim, lid, noise(grey.size(), CV_32F), raw, bgr;
        grey.convertTo(dim, CV_32F, light);
        cv::GaussianBlur(dim, lid, cv::Size(0, 0), 160);
        rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
        cv::Mat(lid + noise + 8).convertTo(raw, CV_8U);  // Bayer raw, a black level of 8
        cv::cvtColor(raw, bgr, cv::COLOR_BayerBG2BGR);
        std::vector<uchar> jpeg;
        ASSERT_TRUE(cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality}));
        const cv::Mat frame = cv::imdecode(jpeg, cv::IMREAD_COLOR);
        const std::optional<BlindImageMeasure> m = MeasureBlindImage(frame);
        ASSERT_TRUE(m);
        EXPECT_NE(BlindImageProblem(frame), "")
            << "sigma " << sigma << ", quality " << quality << ", light " << light << ": structure "
            << m->structure << ", coarser " << m->coarser;
        cv::Mat small;  // the same at the descriptors' own size
        cv::resize(frame, small, cv::Size(64, 32), 0, 0, cv::INTER_AREA);
        EXPECT_NE(BlindImageProblem(small), "") << "64 x 32, sigma " << sigma;
      }
    }
  }
}

}  // namespace
}  // namespace bsf_vpr
