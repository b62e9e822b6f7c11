// bsf_import's errors: one line naming the file (and line) or the flag, exit status 2, and
// nothing written, also when the failure comes while the bags are being written. Fixtures
// as in test_import.cpp (real Nordland images, synthetic trajectories).
#include <gtest/gtest.h>

#include <map>

#include "test/tools/import/import_fixtures.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;
using testing::ExpectOneLineRefusal;
using testing::kEpochUs;
using testing::kLat0;
using testing::kLon0;
using testing::Result;
using ImportErrors = testing::ImportTest;

TEST_F(ImportErrors, BadInputIsOneLineNamingTheFileAndNothingIsWritten) {
  // A small generic traversal: 20 images 1 m apart heading east.
  const std::vector<std::string> images = testing::NordlandImages("summer", 20);
  fs::create_directories(dir_ + "/img");
  std::ofstream csv(dir_ + "/img.csv"), geo(dir_ + "/geo.csv");
  csv << "timestamp,x,y,z,yaw\n";
  geo << "timestamp,lat,lon\n";
  for (size_t k = 0; k < images.size(); ++k) {
    fs::copy_file(images[k], dir_ + "/img/" + fs::path(images[k]).filename().string());
    csv << 10 + k << "," << k << ",0,0,0\n";
    geo << 10 + k << "," << kLat0 << "," << kLon0 + 1e-5 * k << "\n";
  }
  csv.close(), geo.close();
  std::ofstream(dir_ + "/short.csv") << "timestamp,x,y,z,yaw\n1,0,0,0,0\n2,1,0,0,0\n3,2,0,0,0\n";
  std::ofstream(dir_ + "/back.csv") << "timestamp,x,y,z,yaw\n2,0,0,0,0\n1,1,0,0,0\n";
  std::ofstream(dir_ + "/far.csv") << "timestamp,x,y,z,yaw\n1,500,0,0,0\n2,501,0,0,0\n";
  std::ofstream(dir_ + "/nolat.csv") << "frame,lon\n1,14\n";
  std::ofstream(dir_ + "/later.csv") << "frame,lat,lon\n1000,67,14\n1001,67,14.0001\n";
  fs::create_directories(dir_ + "/two");
  fs::copy_file(images[0], dir_ + "/two/a.png");
  fs::copy_file(images[1], dir_ + "/two/b.png");
  const std::string rc = testing::WriteRobotCar(dir_, "rc", testing::RouteA(0.25),
                                                testing::RouteA(0.07), "summer", kEpochUs);
  {  // line 4 of ins.csv (the third sample) loses its northing
    std::vector<std::string> lines = testing::Lines(rc + "/gps/ins.csv");
    lines[3].replace(lines[3].find(",5735"), 5, ",x735");
    std::ofstream out(rc + "/gps/ins.csv");
    for (const std::string& l : lines) out << l << "\n";
  }
  const std::string ok = " --reference a=" + dir_ + "/img," + dir_ + "/img.csv";
  const std::string gen = "--layout generic" + ok;
  const std::string out = " --out " + dir_ + "/new";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {ok + out, "no --layout"},
      {"--layout tram" + ok + out, "--layout must be robotcar | nordland | generic, got 'tram'"},
      {gen + " --reference a/b=" + dir_ + "/img," + dir_ + "/img.csv" + out, "NAME may hold"},
      {gen + " --reference a=x,y" + out, "--reference: the name 'a' is given twice"},
      {gen + " --camera mono_left" + out, "--camera goes with --layout robotcar"},
      {gen + " --resize 0x10" + out, "--resize: width and height must lie in 1..16384"},
      {gen + " --max-yaw-difference-deg 200" + out, "--max-yaw-difference-deg"},
      {gen + " --rate 10" + out, "unknown option '--rate'"},
      {gen + " --query q=" + dir_ + "/img," + dir_ + "/short.csv" + out,
       "query 'q': '" + dir_ + "/short.csv' has 3 rows, '" + dir_ + "/img' 20 images"},
      {gen + " --query q=" + dir_ + "/two," + dir_ + "/back.csv" + out,
       "'" + dir_ + "/back.csv' line 3: timestamps must not decrease"},
      {gen + " --query q=" + dir_ + "/img," + dir_ + "/geo.csv" + out,
       "traversal 'q' has latitude/longitude fixes, the first reference 'a' x,y,z,yaw poses"},
      {gen + " --reference far=" + dir_ + "/two," + dir_ + "/far.csv" + out,
       "reference 'far' passes no place of 'a'"},
      {gen + " --tolerance 3" + out, "--tolerance is for traversals without poses"},
      {"--layout nordland --reference n=" + dir_ + "/img --tolerance-m 3" + out,
       "--tolerance-m needs poses: these traversals have none"},
      {"--layout nordland --reference n=" + dir_ + "/img," + dir_ + "/later.csv" + out,
       "reference 'n' has no frame with a pose (20 frames outside the pose log)"},
      {"--layout nordland --reference n=" + dir_ + "/img," + dir_ + "/nolat.csv" + out,
       "'" + dir_ + "/nolat.csv' line 1: no column 'latitude' or 'lat'"},
      {"--layout robotcar --reference r=" + rc + out,
       "reference 'r': '" + rc +
           "/gps/ins.csv' line 4: column 'northing' expects a number, "
           "got 'x735"},
      {"--layout robotcar --reference r=" + dir_ + "/img" + out,
       "no camera folder '" + dir_ + "/img/stereo/centre'"},
  };
  for (const auto& [args, fragment] : cases) {
    ExpectOneLineRefusal(Run(args), fragment, args);
    EXPECT_FALSE(fs::exists(dir_ + "/new")) << args;
  }

  // A failure while the bags are written (a query image that does not decode) leaves an
  // earlier import in the same folder as it was, and no temporary file.
  const std::string query = " --query q=" + dir_ + "/q," + dir_ + "/q.csv";
  fs::copy(dir_ + "/img", dir_ + "/q");
  fs::copy_file(dir_ + "/img.csv", dir_ + "/q.csv");
  ASSERT_EQ(Run(gen + query + " --out " + dir_ + "/out").exit_code, 0);
  const auto listing = [&] {
    std::map<std::string, std::vector<std::string>> files;
    for (const auto& e : fs::directory_iterator(dir_ + "/out"))
      files[e.path().filename().string()] = testing::Lines(e.path().string());
    return files;
  };
  const auto before = listing();
  std::ofstream(dir_ + "/q/zz_broken.png") << "not a png";
  std::ofstream(dir_ + "/q.csv", std::ios::app) << "40,20,0,0,0\n";
  const Result broken = Run(gen + query + " --out " + dir_ + "/out");
  EXPECT_EQ(broken.exit_code, 2);
  EXPECT_NE(broken.output.find("cannot decode image '" + dir_ + "/q/zz_broken.png'"),
            std::string::npos)
      << broken.output;
  EXPECT_EQ(listing(), before);
  // ... and one into a new folder leaves no folder.
  EXPECT_EQ(Run(gen + query + out).exit_code, 2);
  EXPECT_FALSE(fs::exists(dir_ + "/new"));
}

}  // namespace
}  // namespace bsf_vpr
