#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bsf_vpr/core/reference_set.h"
#include "test/core/test_util.h"

namespace bsf_vpr {
namespace {

TEST(ReferenceSets, HoldsSetsOfOneDimensionOverASharedPlaceIndex) {
  ReferenceSets map;
  map.Add(MakeReferenceSet("summer", testing::RandomMatrix(10, 6, 1), "sunny"));
  ReferenceSet partial;
  partial.name = "night";
  partial.descriptors = testing::RandomMatrix(2, 6, 2);
  partial.place_ids = {3, 14};
  partial.poses = {{1, 0, 0, 0}, {2, 0, 0, 0}};
  map.Add(partial);
  EXPECT_EQ(map.num_sets(), 2);
  EXPECT_EQ(map.num_places(), 15);
  EXPECT_EQ(map.dimension(), 6);
  EXPECT_EQ(map.IndexOf("night"), 1);
  EXPECT_EQ(map.SetNames(), (std::vector<std::string>{"summer", "night"}));
  ASSERT_TRUE(map.PoseOf(14).has_value());
  EXPECT_DOUBLE_EQ(map.PoseOf(14)->x_m, 2);
  EXPECT_FALSE(map.PoseOf(0).has_value());
  EXPECT_GT(map.set(0).MemoryBytes(), 10u * 6u * 4u - 1u);
  EXPECT_FALSE(map.PoseOf(-1).has_value());
  EXPECT_FALSE(map.PoseOf(99).has_value());
  // The first set with a pose for a place wins; removing it exposes the next one's.
  ReferenceSet day;
  day.name = "day";
  day.descriptors = testing::RandomMatrix(2, 6, 3);
  day.place_ids = {14, 0};
  day.poses = {{7, 0, 0, 0}, {8, 0, 0, 0}};
  map.Add(day);
  EXPECT_DOUBLE_EQ(map.PoseOf(14)->x_m, 2);
  EXPECT_DOUBLE_EQ(map.PoseOf(0)->x_m, 8);
  EXPECT_TRUE(map.Remove("night"));
  EXPECT_DOUBLE_EQ(map.PoseOf(14)->x_m, 7);
  EXPECT_FALSE(map.PoseOf(3).has_value());
  EXPECT_TRUE(map.Remove("day"));
  EXPECT_FALSE(map.Remove("night"));
  EXPECT_EQ(map.num_places(), 10);
  EXPECT_FALSE(map.PoseOf(0).has_value());
}

TEST(ReferenceSets, RefusesSetsThatPutAPlaceElsewhere) {
  ReferenceSets map;
  ReferenceSet summer = MakeReferenceSet("summer", testing::RandomMatrix(3, 4, 1));
  summer.poses = {{0, 0, 0, 0}, {1, 0, 0, 0}, {2, 0, 0, 0}};
  map.Add(summer);
  ReferenceSet elsewhere = MakeReferenceSet("elsewhere", testing::RandomMatrix(3, 4, 2));
  elsewhere.poses = {{0, 3, 0, 0}, {501, 0, 0, 0}, {2, 0, 0, 0}};  // place 1: 500 m away
  try {
    map.Add(elsewhere);
    ADD_FAILURE() << "a set 500 m off was loaded";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("puts place 1 500.0 m from where the loaded sets have "
                                         "it (tolerance 25.0 m)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(map.num_sets(), 1);
  // Places the map has no pose for, and sets without poses, are not checked.
  ReferenceSet beyond = MakeReferenceSet("beyond", testing::RandomMatrix(2, 4, 3));
  beyond.place_ids = {3, 4};
  beyond.poses = {{900, 0, 0, 0}, {901, 0, 0, 0}};
  map.Add(beyond);
  map.Add(MakeReferenceSet("no_poses", testing::RandomMatrix(3, 4, 4)));
  map.SetPlacePoseTolerance(std::numeric_limits<double>::infinity());
  map.Add(elsewhere);
  EXPECT_EQ(map.num_sets(), 4);
}

TEST(ReferenceSets, RefusesBadSetsAndStaysUnchanged) {
  ReferenceSets map;
  map.Add(MakeReferenceSet("a", testing::RandomMatrix(4, 3, 1)));
  auto expect_refused = [&](ReferenceSet s, const std::string& fragment) {
    try {
      map.Add(std::move(s));
      ADD_FAILURE() << "accepted a set that should fail with '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
    EXPECT_EQ(map.num_sets(), 1);
    EXPECT_EQ(map.num_places(), 4);
    EXPECT_EQ(map.dimension(), 3);
  };
  expect_refused(MakeReferenceSet("a", testing::RandomMatrix(4, 3, 2)), "already loaded");
  expect_refused(MakeReferenceSet("b", testing::RandomMatrix(4, 5, 2)), "dimension 5");
  expect_refused(MakeReferenceSet("c", RowMatrixXf(0, 3)), "empty");
  expect_refused(MakeReferenceSet("", testing::RandomMatrix(4, 3, 2)), "name");
  RowMatrixXf nan = testing::RandomMatrix(4, 3, 2);
  nan(2, 1) = NAN;
  expect_refused(MakeReferenceSet("d", nan), "row 2");
  ReferenceSet neg = MakeReferenceSet("e", testing::RandomMatrix(2, 3, 2));
  neg.place_ids = {-1, 0};
  expect_refused(neg, "negative");
  ReferenceSet poses = MakeReferenceSet("f", testing::RandomMatrix(2, 3, 2));
  poses.poses.resize(1);
  expect_refused(poses, "poses");
  // Absurd place ids are refused before the place index grows (it used to grow to 2e9
  // places and then fail to allocate, leaving the map broken; INT_MAX overflowed).
  ReferenceSet far = MakeReferenceSet("g", testing::RandomMatrix(3, 3, 2));
  far.place_ids = {0, 1, 2000000000};
  expect_refused(far, "2000000000");
  far.place_ids = {0, 1, std::numeric_limits<int>::max()};
  expect_refused(far, "place id");
  far.place_ids = {0, 1, 500000};  // beyond 1000 x max(3 descriptors, 4 places) + 1000
  expect_refused(far, "far beyond");
  // Finite values whose squared norm overflows float32 would make every distance inf/NaN.
  RowMatrixXf huge = testing::RandomMatrix(4, 3, 2);
  huge(1, 0) = 3.0e38f;
  expect_refused(MakeReferenceSet("h", huge), "norm too large");
  // Sparse coverage well within the bound is accepted.
  ReferenceSet sparse = MakeReferenceSet("s", testing::RandomMatrix(3, 3, 2));
  sparse.place_ids = {0, 1500, 3000};
  map.Add(sparse);
  EXPECT_EQ(map.num_places(), 3001);
  EXPECT_TRUE(map.Remove("s"));
  EXPECT_EQ(map.num_places(), 4);
}

TEST(ReferenceSets, RefusesPosesThatAreNotFiniteOrBeyondAnyEarthFrameNamingThePlace) {
  ReferenceSets map;
  ReferenceSet s = MakeReferenceSet("route", testing::RandomMatrix(3, 2, 1));
  s.place_ids = {4, 5, 6};
  // A southern UTM northing (false northing 1e7 m) and an ECEF coordinate are real poses.
  s.poses = {{5.0e5, 9.99e6, 0, 0}, {-6.4e6, 1e7, 100, -3}, {0, 0, 0, 12.0}};
  const auto refusal = [&map](const ReferenceSet& set) {
    try {
      ReferenceSets(map).Add(set);
      return std::string("accepted");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
  };
  EXPECT_EQ(refusal(s), "accepted");
  for (const auto& [pose, value] :
       std::vector<std::pair<PlacePose, std::string>>{{{NAN, 0, 0, 0}, "x = nan"},
                                                      {{0, 0, 0, INFINITY}, "yaw = inf"},
                                                      {{0, 1e12, 0, 0}, "y = 1e+12"},
                                                      {{0, 0, -2e8, 0}, "z = -2e+08"}}) {
    ReferenceSet bad = s;
    bad.poses[1] = pose;
    const std::string why = refusal(bad);
    for (const std::string& part :
         std::vector<std::string>{"reference set 'route'", "row 1", "place 5", value}) {
      EXPECT_NE(why.find(part), std::string::npos) << part << " in: " << why;
    }
    // A layout alone (a shard's set in a sharded map's combiner) refuses it too.
    SetLayout layout;
    layout.name = "route";
    layout.dimension = 2;
    layout.place_ids = bad.place_ids;
    layout.poses = bad.poses;
    PlaceLayout combiner;
    EXPECT_THROW(combiner.Add(layout), std::invalid_argument) << value;
    EXPECT_EQ(combiner.num_sets(), 0);
  }
  EXPECT_EQ(PoseProblem(PlacePose{1, 2, 3, 4}), "");
}

TEST(ReferenceSets, RefusesSetsWhoseImagesDoNotNameOneRelativeFilePerRow) {
  ReferenceSets map;
  auto expect_refused = [&](const ReferenceSet& s, const std::string& fragment) {
    try {
      map.Add(s);
      ADD_FAILURE() << "accepted a set that should fail with '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
    EXPECT_EQ(map.num_sets(), 0);
  };
  ReferenceSet s = MakeReferenceSet("i", testing::RandomMatrix(3, 2, 1));
  s.images = "/data/i";
  s.image_files = {"a.png", "b.png"};
  expect_refused(s, "2 image files for 3 descriptors");
  s.image_files = {"a.png", "b.png", "c.png", "d.png"};
  expect_refused(s, "4 image files for 3 descriptors");
  s.image_files.clear();
  expect_refused(s, "an images folder but no image files");
  s.images.clear();
  s.image_files = {"a.png", "b.png", "c.png"};
  expect_refused(s, "lists image files but no images folder");
  s.images = "/data/i";
  for (const auto& [file, fragment] : std::vector<std::pair<std::string, std::string>>{
           {"/etc/c.png", "row 2 '/etc/c.png' is absolute"},
           {"../c.png", "row 2 '../c.png' has a '..' part"},
           {"x/../../c.png", "'..' part"},
           {"x/..", "'..' part"}}) {
    s.image_files[2] = file;
    expect_refused(s, fragment);
  }
  // Names that only look like a climb, subfolders and "." parts stay below the folder.
  for (const std::string file : {"..c.png", "c...png", "x/c.png", "./c.png", "x/..y/c.png"}) {
    EXPECT_EQ(ImageFileProblem(file), "") << file;
  }
  // An empty entry: the row has no image (a recording kept none for it).
  EXPECT_EQ(ImageFileProblem(""), "");
  s.image_files[2] = "";
  map.Add(s);
  map = ReferenceSets();
  s.image_files[2] = "x/..y/c.png";
  map.Add(s);
  EXPECT_EQ(map.set(0).images(), "/data/i");
  EXPECT_EQ(map.set(0).image_files(), s.image_files);
}

TEST(ReferenceSets, AQueryOfZerosIsRefusedAsCarryingNoInformation) {
  ReferenceSets map;
  map.Add(MakeReferenceSet("a", testing::RandomMatrix(4, 3, 1)));
  try {
    map.CheckQuery(Eigen::VectorXf::Zero(3));
    ADD_FAILURE() << "a zero query was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("descriptor is all zeros: it carries no information"),
              std::string::npos)
        << e.what();
  }
  // Constant but not zero: an L2-normalised descriptor may be 1/sqrt(D) everywhere.
  EXPECT_NO_THROW(map.CheckQuery(Eigen::VectorXf::Constant(3, 1 / std::sqrt(3.0f))));
  Eigen::VectorXf tiny = Eigen::VectorXf::Zero(3);
  tiny(1) = 1e-30f;  // its square underflows float32, not the check
  EXPECT_NO_THROW(map.CheckQuery(tiny));
  // A reference set's row of zeros (a black frame of a traversal) stays: dropping it would
  // shift every later place, and its distances are finite.
  RowMatrixXf black = testing::RandomMatrix(4, 3, 2);
  black.row(2).setZero();
  EXPECT_NO_THROW(map.Add(MakeReferenceSet("b", black)));
}

TEST(ReferenceSets, DescriptorProblemNamesNanInfinityAndOverflow) {
  Eigen::RowVectorXf d = Eigen::RowVectorXf::Ones(8);
  EXPECT_EQ(DescriptorProblem(d), "");
  d(2) = 1e19f;  // squared 1e38 > the bound
  EXPECT_NE(DescriptorProblem(d).find("norm too large"), std::string::npos);
  d(2) = NAN;
  EXPECT_NE(DescriptorProblem(d).find("NaN"), std::string::npos);
  d(2) = -INFINITY;
  EXPECT_NE(DescriptorProblem(d).find("infinity"), std::string::npos);
  for (int n : {1, 5, 7, 4099}) {  // every position of the four sums and the tail
    for (int at : {0, n / 2, n - 1}) {
      Eigen::RowVectorXf e = Eigen::RowVectorXf::Ones(n);
      EXPECT_EQ(DescriptorProblem(e), "");
      e(at) = NAN;
      EXPECT_NE(DescriptorProblem(e).find("NaN"), std::string::npos) << n << " " << at;
      e(at) = INFINITY;
      EXPECT_NE(DescriptorProblem(e).find("infinity"), std::string::npos) << n << " " << at;
    }
  }
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

TEST(ReferenceSets, MedianPlaceSpacingFollowsTheLoadedPoses) {
  ReferenceSets map;
  map.Add(MakeReferenceSet("no_poses", testing::RandomMatrix(5, 3, 1)));
  EXPECT_FALSE(map.MedianPlaceSpacing().has_value());
  ReferenceSet route = MakeReferenceSet("route", testing::RandomMatrix(5, 3, 2));
  route.poses = {{0, 0, 0, 0}, {2, 0, 0, 0}, {4, 0, 0, 0}, {9, 0, 0, 0}, {11, 0, 0, 0}};
  map.Add(route);
  EXPECT_DOUBLE_EQ(*map.MedianPlaceSpacing(), 2.0);  // gaps 2, 2, 5, 2
  EXPECT_TRUE(map.Remove("route"));
  EXPECT_FALSE(map.MedianPlaceSpacing().has_value());
}

}  // namespace
}  // namespace bsf_vpr
