// Regression tests on the real multi-traversal data shipped in data/: several reference sets
// fused. The figures are pinned (measured on 2026-11-22, with the paper's selection rule, the
// product fusion and the one-sided likelihood given explicitly, so that a change of the
// defaults does not move them; the default's own figures since 2026-11-23): a change in
// selection, likelihood or fusion that moves any AUC by more than kTolerance fails here.
//
//   Nordland-100 (data/nordland_subset100/64x32): 100 places in three seasons; each season
//   in turn is the query traversal, the other two the reference sets; patch-normalised and
//   HOG descriptors, cosine distance, +-2 places.
//   VPR-Bench Corridor (data/vprbench_corridor): 10 techniques' similarity matrices as 10
//   sources of evidence, with their ground truth.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "test/tools/tool_test_util.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;
using testing::Evaluate;
using testing::Summary;

const std::string kData = std::string(BSF_SOURCE_DIR) + "/data/";
constexpr double kTolerance = 0.002;
// The paper's selection and product fusion with the one-sided likelihood, spelled out.
const std::string kPaperMode =
    " --selection relative --gamma-fraction 0.04 --likelihood one_sided --fusion product"
    " --off-map false";

// bsf_evaluate's inputs for Nordland-100: QUERY's frames against the other two seasons.
std::string NordlandHundredArgs(const std::string& query, const std::string& descriptor) {
  const std::string n100 = kData + "nordland_subset100/64x32/";
  std::string args;
  for (const std::string season : {"summer", "fall", "winter"}) {
    if (season != query) args += " --reference " + season + "=" + n100 + season;
  }
  return args + " --query " + n100 + query + " --image-descriptor " + descriptor +
         " --distance cosine --tolerance 2";
}

// bsf_evaluate's inputs for the Corridor: the 10 techniques' similarities and the ground truth.
std::string CorridorArgs() {
  const std::string corridor = kData + "vprbench_corridor/";
  std::string args = " --ground-truth " + corridor + "ground_truth.csv";
  for (const std::string t : {"AMOSNet", "AlexNet_VPR", "CALC", "CoHOG", "HOG", "HybridNet",
                              "NetVLAD", "RegionVLAD", "ap-gem-r101", "denseVLAD"}) {
    args += " --similarities " + t + "=" + corridor + t + ".npy";
  }
  return args;
}

struct Case {
  std::string query, descriptor;
  std::map<std::string, double> auc;  // method -> AUC
};

class RealData : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/bsf_real_XXXXXX";
    dir_ = mkdtemp(tmpl);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Runs bsf_evaluate; returns its summary (method -> column -> value), empty on failure.
  std::map<std::string, std::map<std::string, double>> Run(const std::string& args) {
    const std::string out = dir_ + "/" + std::to_string(runs_++);
    const testing::Result r = Evaluate(args + " --no-progress --out " + out);
    EXPECT_EQ(r.exit_code, 0) << r.output;
    if (r.exit_code != 0) return {};
    return Summary(out);
  }
  void ExpectAucs(const std::string& args, const std::map<std::string, double>& expected,
                  const std::string& what, const std::string& mode = kPaperMode) {
    const auto summary = Run(args + mode);
    for (const auto& [method, auc] : expected) {
      ASSERT_TRUE(summary.count(method)) << what << ": no row for " << method;
      EXPECT_NEAR(summary.at(method).at("auc"), auc, kTolerance) << what << " " << method;
    }
  }
  std::string dir_;
  int runs_ = 0;
};

TEST_F(RealData, NordlandHundredFusesTwoSeasonsForTheThird) {
  const std::vector<Case> cases = {
      {"winter",
       "patchnorm",
       {{"bsf", 0.4284},
        {"bayes_full", 0.4458},
        {"med", 0.4003},
        {"med_selective", 0.4820},
        {"bayes:fall", 0.4676},
        {"nn:fall", 0.4663},
        {"bayes:summer", 0.3762}}},
      {"winter",
       "hog",
       {{"bsf", 0.8864},
        {"bayes_full", 0.8920},
        {"med", 0.7737},
        {"med_selective", 0.7955},
        {"bayes:fall", 0.8889},
        {"nn:fall", 0.8006}}},
      {"summer",
       "patchnorm",
       {{"bsf", 1.0},
        {"bayes_full", 0.9783},
        {"med", 0.9772},
        {"med_selective", 1.0},
        {"bayes:winter", 0.4689}}},
      {"summer",
       "hog",
       {{"bsf", 1.0}, {"bayes_full", 0.9692}, {"med", 0.9849}, {"bayes:winter", 0.8197}}},
      {"fall",
       "patchnorm",
       {{"bsf", 1.0}, {"bayes_full", 1.0}, {"med", 0.9770}, {"bayes:winter", 0.4406}}},
      {"fall",
       "hog",
       {{"bsf", 1.0}, {"bayes_full", 0.9372}, {"med", 0.9886}, {"bayes:winter", 0.8583}}},
  };
  for (const Case& c : cases) {
    ExpectAucs(NordlandHundredArgs(c.query, c.descriptor), c.auc, c.query + "/" + c.descriptor);
  }
}

TEST_F(RealData, CorridorFusesTenTechniquesWithTheirOwnScales) {
  const std::string args =
      CorridorArgs() + " --methods bsf,bayes_full,med,med_selective,nn:HybridNet,nn:NetVLAD";
  // The paper's relative rule compares raw minimum distances: across techniques whose
  // scales differ it selects by scale, not by evidence (bsf 0.222).
  ExpectAucs(args,
             {{"bsf", 0.2222},
              {"bayes_full", 0.9013},
              {"med", 0.9094},
              {"med_selective", 0.2680},
              {"nn:HybridNet", 0.8441},
              {"nn:NetVLAD", 0.5553}},
             "corridor, relative selection");
  // The default: each technique its own descriptor group, so the ten multiply (bayes_full,
  // 0.9013, without the places' means; with them, each technique's places corrected by
  // their mean distance to the queries so far, 0.9417; with the hypothesis "no place of the
  // map" too, the default, 0.9486). Declared one descriptor, the mixture weighs them by raw
  // minima (0.250 without off_map, 0.276 with it); the default's hypotheses over the stream
  // recover most of what the product of ten independent techniques gives.
  ExpectAucs(args, {{"bsf", 0.9013}}, "corridor, default without the places' means",
             " --fusion-place-means false");
  ExpectAucs(args, {{"bsf", 0.9417}}, "corridor, default without off_map", " --off-map false");
  ExpectAucs(args, {{"bsf", 0.9486}}, "corridor, default", "");
  ExpectAucs(args, {{"bsf", 0.2762}}, "corridor, mixture of one descriptor",
             " --same-descriptor true --fusion mixture");
  ExpectAucs(args, {{"bsf", 0.8029}}, "corridor, default, one descriptor",
             " --same-descriptor true");
  const testing::Result refused =
      Evaluate(" --reference a=" + kData + "gardens_point_hdc_delf/day_left.npy --query " + kData +
               "gardens_point_hdc_delf/night_right.npy --tolerance 8 --same-descriptor true");
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.output.find("--same-descriptor goes with --distances/--similarities"),
            std::string::npos)
      << refused.output;
  // The scale-free rule.
  ExpectAucs(args, {{"bsf", 0.7493}, {"med_selective", 0.7068}}, "corridor, standardized",
             " --selection standardized --gamma-fraction 0.04 --likelihood one_sided"
             " --fusion product");
}

// The pca first stage (first_stage.h) on the real data, for single images and over time
// (+seq, +filter, which read every distance, most of them approximate):
//  - Nordland 1500 with HOG (D = 756 > d' = 256, 1500 rows): re-ranking 1% of the rows (15;
//    the default's share of a 100,000-place set) keeps R@1 within one point of exact search;
//    32 dimensions and 5 candidates lose recall.
//  - Gardens Point (HDC-DELF, 4096-D, 200 rows): a basis fitted to all rows spans them, so the
//    first stage is exact but for int8 rounding; fitted to half of them it no longer fits
//    the other half (the energy it keeps falls, printed in the description) and recall drops:
//    where the approximation breaks (docs/performance.md).
TEST_F(RealData, ThePcaFirstStageKeepsRecallAtOneWithinOnePointOfExactWhereItFitsTheMap) {
  struct PcaCase {
    std::string name, args, methods, kept, broken;
  };
  const std::vector<PcaCase> cases = {
      {"Nordland 1500 (HOG)",
       " --reference summer=" + kData + "nordland_64x32/summer --query " + kData +
           "nordland_64x32/winter --image-descriptor hog --tolerance 2",
       "bsf,bsf+seq,bsf+filter", " --first-stage pca --rerank-candidates 15",
       " --first-stage pca --first-stage-dimensions 32 --rerank-candidates 5"},
      {"Gardens Point (HDC-DELF, 4096-D)",
       " --reference day=" + kData + "gardens_point_hdc_delf/day_left.npy --query " + kData +
           "gardens_point_hdc_delf/night_right.npy --distance cosine --tolerance 8",
       "bsf,bsf+seq", " --first-stage pca --rerank-candidates 2",
       " --first-stage pca --rerank-candidates 2 --first-stage-sample-rows 100"},
  };
  for (const PcaCase& c : cases) {
    const auto exact = Run(c.args + " --methods " + c.methods);
    const auto kept = Run(c.args + " --methods " + c.methods + c.kept);
    const auto broken = Run(c.args + " --methods " + c.methods + c.broken);
    ASSERT_FALSE(exact.empty() || kept.empty() || broken.empty()) << c.name;
    double loss = 0;
    for (const auto& [method, row] : exact) {
      const double r1 = row.at("r_at_1");
      // One point, inclusive (the default's Gardens Point bsf keeps 171 of 200 against 173).
      EXPECT_NEAR(kept.at(method).at("r_at_1"), r1, 0.01 + 1e-9) << c.name << " " << method;
      loss = std::max(loss, r1 - broken.at(method).at("r_at_1"));
    }
    EXPECT_GE(loss, 0.02) << c.name << ": " << c.broken << " lost no recall";
  }
}

// The default bsf (no option given) on every real case in the repository against the
// paper's bsf, bayes_full, med, med_selective, the best single reference (nn: or bayes:) and
// the descriptor-level methods (mean_descriptor, union_nn, subspace, discriminant, where the
// sets share places), all run here in the same call: its mean AUC is above each
// alternative's mean (over the cases that have it), and its AUC and R@100P per case and its
// worst regret (the AUC below the best alternative of the case) are pinned. With the
// discriminant as one more hypothesis (issue 42) the default is the best of every case
// (winter HOG 0.855 -> 0.936, above bayes_full's 0.892; winter patch-normalised 0.590 ->
// 0.622); the worst regret is 0, the ties at 1.0. With the hypothesis "no place of the map"
// (issue 43) the on-map queries' confidences also weigh how well the route predicts them:
// winter patch-normalised 0.633, R@100P 0.24 -> 0.34, Corridor 0.949.
TEST_F(RealData, TheDefaultFusionOnEveryRealCase) {
  struct RealCase {
    std::string name, args;
    double auc, r_at_100p;  // the default bsf's, pinned
  };
  std::vector<RealCase> cases;
  const std::map<std::string, std::pair<double, double>> n100_pins = {
      {"winter/patchnorm", {0.6334, 0.34}}, {"winter/hog", {0.9357, 0.78}},
      {"summer/patchnorm", {1.0, 1.0}},     {"summer/hog", {1.0, 1.0}},
      {"fall/patchnorm", {1.0, 1.0}},       {"fall/hog", {1.0, 1.0}}};
  for (const std::string query : {"winter", "summer", "fall"}) {
    for (const std::string descriptor : {"patchnorm", "hog"}) {
      const auto pin = n100_pins.at(query + "/" + descriptor);
      cases.push_back({"Nordland-100 " + query + "/" + descriptor,
                       NordlandHundredArgs(query, descriptor), pin.first, pin.second});
    }
  }
  cases.push_back({"Corridor", CorridorArgs(), 0.9486, 0.2613});
  cases.push_back({"Gardens Point",
                   " --reference day=" + kData + "gardens_point_hdc_delf/day_left.npy --query " +
                       kData +
                       "gardens_point_hdc_delf/night_right.npy --distance cosine"
                       " --tolerance 8",
                   0.8148, 0.115});
  cases.push_back({"Nordland 1500",
                   " --reference winter=" + kData + "nordland_64x32/winter --query " + kData +
                       "nordland_64x32/summer --distance cosine --tolerance 2",
                   0.1992, 0.0153});
  double sum_default = 0, worst = -1;
  std::map<std::string, double> sum;  // per alternative
  std::map<std::string, int> count;   // the cases that have it
  std::string worst_case;
  for (const RealCase& c : cases) {
    const auto fused = Run(c.args + " --methods all");
    const auto paper = Run(c.args + " --methods bsf" + kPaperMode);
    ASSERT_TRUE(fused.count("bsf") && paper.count("bsf")) << c.name;
    double best = paper.at("bsf").at("auc");
    std::string best_name = "bsf (paper)";
    for (const auto& [method, row] : fused) {
      if (method != "bsf" && row.at("auc") > best) {
        best = row.at("auc");
        best_name = method;
      }
    }
    const double mine = fused.at("bsf").at("auc");
    std::printf("%-28s default %.4f / %.2f, best alternative %.4f (%s)\n", c.name.c_str(), mine,
                fused.at("bsf").at("r_at_100p"), best, best_name.c_str());
    EXPECT_NEAR(mine, c.auc, kTolerance) << c.name;
    EXPECT_NEAR(fused.at("bsf").at("r_at_100p"), c.r_at_100p, kTolerance) << c.name;
    if (best - mine > worst) {
      worst = best - mine;
      worst_case = c.name + " (" + best_name + ")";
    }
    std::map<std::string, double> auc = {{"bsf (paper)", paper.at("bsf").at("auc")},
                                         {"best single", 0.0}};
    for (const auto& [method, row] : fused) {
      if (method.rfind("nn:", 0) == 0 || method.rfind("bayes:", 0) == 0) {
        auc["best single"] = std::max(auc["best single"], row.at("auc"));
      } else if (method != "bsf") {
        auc[method] = row.at("auc");
      }
    }
    // The default's mean against each alternative's, over the cases that have it.
    for (const auto& [method, value] : auc) {
      sum[method] += value;
      sum["default vs " + method] += mine;
      ++count[method];
    }
    sum_default += mine;
  }
  const double n = static_cast<double>(cases.size());
  std::printf("mean AUC: default %.4f", sum_default / n);
  for (const auto& [method, cases_with] : count) {
    const double theirs = sum[method] / cases_with, ours = sum["default vs " + method] / cases_with;
    std::printf("; %s %.4f (default %.4f over its %d)", method.c_str(), theirs, ours, cases_with);
    EXPECT_GT(ours, theirs) << "mean AUC of the default and " << method;
  }
  EXPECT_EQ(count.at("discriminant"), 6);  // the Nordland-100 cases: sets that share places
  std::printf("; worst regret %.4f, %s\n", worst, worst_case.c_str());
  EXPECT_NEAR(worst, 0.0, kTolerance) << worst_case;  // ties at 1.0
}

// Issue 29: cases where the sets are alternative conditions and cases where they are
// complementary evidence, from real frames. Three traversals of Nordland-100 (winter,
// summer, fall; data/nordland_subset100/256x144), each seen from a viewpoint of its own:
// a crop of 70% of each frame (bsf_make_views), centred (c), moved 2.5% of the width left
// or right (l, r) or 5% (L, R); or the 64x32 frames as shipped (o). Each traversal in turn
// is the query against the other two. The sets that share the query's viewpoint and those
// that share its season are then wrong in their own ways. The rule was designed on the
// patch-normalised cases and these HOG cases were first run once it was fixed
// (docs/results.md, Study 7).
//
// The figure of merit of each case: the default's AUC below the best of the paper's bsf,
// bayes_full, med, med_selective and the best single reference (nn: or bayes:), all under
// the paper's options, and of the descriptor-level methods under the defaults, run here. Pinned per
// family: the default's mean AUC and worst regret. Checked: over all the families' cases the
// default's mean AUC is above every alternative's, the best single reference's too (chosen per
// case, with hindsight). The families held out on 2026-12-03 were first run with the places' means
// fixed.
TEST_F(RealData, TheDefaultFusionAcrossViewpointsAndSeasons) {
  const std::string frames = kData + "nordland_subset100/256x144/";
  const std::vector<std::string> seasons = {"winter", "summer", "fall"};
  // A family of cases: how the views are cut from the frames, and the descriptor.
  struct Family {
    std::string name;
    double crop, shift;  // l and r move the crop by `shift` widths, L and R by twice that
    std::string descriptor;
    bool held_out;                  // first run with the rule fixed
    double mean_auc, worst_regret;  // the default's, pinned
  };
  const std::vector<Family> families = {
      {"patchnorm", 0.7, 0.025, " --image-descriptor patchnorm", false, 0.7228, 0.0496},
      {"hog", 0.7, 0.025, " --image-descriptor hog", false, 0.9403, 0.0387},
      {"patchnorm 32x16", 0.7, 0.025,
       " --image-descriptor patchnorm --patch-width-px 32 --patch-height-px 16", false, 0.6927,
       0.0973},
      {"patchnorm, 80% crops", 0.8, 0.0375, " --image-descriptor patchnorm", false, 0.6626, 0.2149},
      {"hog 32x16", 0.7, 0.025,
       " --image-descriptor hog --hog-width-px 32 --hog-height-px 16 --hog-cell-px 4", false,
       0.8844, 0.0331},
      {"hog, 80% crops", 0.8, 0.0375, " --image-descriptor hog", true, 0.8880, 0.0373},
      {"patchnorm 48x24", 0.7, 0.025,
       " --image-descriptor patchnorm --patch-width-px 48 --patch-height-px 24", true, 0.6748,
       0.1496},
      {"hog 48x24", 0.7, 0.025, " --image-descriptor hog --hog-width-px 48 --hog-height-px 24",
       true, 0.8765, 0.0401},
  };
  const auto folder = [&](const Family& f, const std::string& season, char view) {
    if (view == 'o') return kData + "nordland_subset100/64x32/" + season;
    const double steps = view == 'c' ? 0
                                     : (view == 'l'   ? -1
                                        : view == 'r' ? 1
                                        : view == 'L' ? -2
                                                      : 2);
    const std::string out = dir_ + "/views/" + std::to_string(f.crop) + "_" +
                            std::to_string(f.shift) + "/" + season + "_" + view;
    if (!fs::exists(out)) {
      const testing::Result r = testing::RunCommand(
          std::string(BSF_MAKE_VIEWS_PATH) + " --images " + frames + season + " --out " + out +
          " --crop " + std::to_string(f.crop) + " --shift " + std::to_string(steps * f.shift));
      EXPECT_EQ(r.exit_code, 0) << r.output;
    }
    return out;
  };
  // The viewpoints of winter, summer and fall.
  const std::vector<std::string> patterns = {"ccr", "crc", "rcc", "ccL", "Lcc",
                                             "cLc", "lcr", "ccc", "ooo"};
  const std::vector<std::string> alternatives = {"bsf (paper)",   "bayes_full",  "med",
                                                 "med_selective", "best single", "mean_descriptor",
                                                 "union_nn",      "subspace",    "discriminant"};
  std::map<std::string, double> everything;  // sums over all the families' cases
  int all_cases = 0;
  for (const Family& family : families) {
    std::map<std::string, double> sum;
    double worst = -1;
    int cases = 0;
    for (const std::string& pattern : patterns) {
      for (size_t q = 0; q < seasons.size(); ++q) {
        std::string args = " --query " + folder(family, seasons[q], pattern[q]);
        std::string name = seasons[q] + "_" + pattern[q] + " <-";
        for (size_t r = 0; r < seasons.size(); ++r) {
          if (r == q) continue;
          const std::string set = seasons[r] + "_" + pattern[r];
          args += " --reference " + set + "=" + folder(family, seasons[r], pattern[r]);
          name += " " + set;
        }
        args += family.descriptor + " --distance cosine --tolerance 2";
        const auto paper = Run(args + " --methods all" + kPaperMode);
        const auto fused =
            Run(args + " --methods bsf,mean_descriptor,union_nn,subspace,discriminant");
        ASSERT_TRUE(paper.count("bsf") && fused.count("bsf")) << name;
        std::map<std::string, double> auc = {{"bsf (paper)", paper.at("bsf").at("auc")},
                                             {"best single", 0.0}};
        for (const auto& [method, row] : paper) {
          if (method.rfind("nn:", 0) == 0 || method.rfind("bayes:", 0) == 0) {
            auc["best single"] = std::max(auc["best single"], row.at("auc"));
          } else if (method != "bsf") {
            auc[method] = row.at("auc");
          }
        }
        for (const auto& [method, row] : fused) {  // the descriptor-level ones: the defaults'
          if (method != "bsf") auc[method] = row.at("auc");
        }
        double best = 0;
        for (const std::string& a : alternatives) {
          best = std::max(best, auc.at(a));
          sum[a] += auc.at(a);
        }
        const double mine = fused.at("bsf").at("auc");
        sum["default"] += mine;
        worst = std::max(worst, best - mine);
        ++cases;
        std::printf("%-22s %-28s default %.3f best %.3f regret %+.3f\n", family.name.c_str(),
                    name.c_str(), mine, best, best - mine);
      }
    }
    const double mean = sum["default"] / cases;
    std::printf("%s%s: default mean AUC %.4f, worst regret %.4f", family.name.c_str(),
                family.held_out ? " (held out)" : "", mean, worst);
    for (const std::string& a : alternatives) std::printf("; %s %.4f", a.c_str(), sum[a] / cases);
    std::printf("\n");
    EXPECT_NEAR(mean, family.mean_auc, kTolerance) << family.name;
    EXPECT_NEAR(worst, family.worst_regret, kTolerance) << family.name;
    for (const auto& [method, total] : sum) everything[method] += total;
    all_cases += cases;
  }
  for (const std::string& a : alternatives) {
    EXPECT_GT(everything["default"] / all_cases, everything[a] / all_cases)
        << "mean AUC over all " << all_cases << " cases of the default and " << a;
  }
}

// The map calibrates itself (Study 8, docs/results.md): Nordland-100 fall queries, all 100,
// against summer and winter cut to places 0-49, so that 48 queries show no place of the map
// (beyond +-2 of place 49). The threshold alone lets bsf+filter accept 6 of them (the route's
// look-alikes, followed by the filter); the rule the map learns from its own two traversals
// for a rate of 1% accepts at most one, and keeps the right matches. (With the cosine
// distance it accepts 4: the rule does not hold on every case yet; docs/results.md.)
TEST_F(RealData, TheMapsOwnRuleTurnsDownLookAlikesPastItsEnd) {
  const std::string n100 = kData + "nordland_subset100/64x32/";
  std::string args;
  for (const std::string season : {"summer", "winter"}) {
    const std::string folder = dir_ + "/" + season;
    fs::create_directories(folder);
    for (int k = 0; k < 50; ++k) {
      char name[16];
      std::snprintf(name, sizeof name, "%03d.png", k);
      fs::create_symlink(n100 + season + "/" + name, folder + "/" + name);
    }
    args += " --reference " + season + "=" + folder;
  }
  std::ofstream truth(dir_ + "/truth.csv");
  truth << "query,correct_places\n";
  for (int q = 0; q < 100; ++q) {
    truth << q << ',';
    for (int p = std::max(0, q - 2); p <= std::min(49, q + 2); ++p) truth << p << ' ';
    truth << '\n';
  }
  truth.close();
  args += " --query " + n100 + "fall --ground-truth " + dir_ +
          "/truth.csv --distance euclidean --methods bsf+filter --no-progress";
  // Right acceptances among the on-map queries, from matches/bsf+filter.csv.
  const auto right = [](const std::string& out) {
    int n = 0;
    const std::vector<std::string> lines = testing::Lines(out + "/matches/bsf+filter.csv");
    for (size_t i = 1; i < lines.size(); ++i) {
      int q, match, accepted;
      if (std::sscanf(lines[i].c_str(), "%d,%d,%*[^,],%d", &q, &match, &accepted) != 3) continue;
      n += accepted && q < 52 && std::abs(match - q) <= 2;
    }
    return n;
  };
  const testing::Result alone = Evaluate(args + " --out " + dir_ + "/alone");
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  const testing::Result ruled =
      Evaluate(args + " --max-false-accept-rate 0.01 --out " + dir_ + "/ruled");
  ASSERT_EQ(ruled.exit_code, 0) << ruled.output;
  EXPECT_NE(ruled.output.find("on this map (bsf+filter): false acceptances"), std::string::npos)
      << ruled.output;
  EXPECT_NE(ruled.output.find("at recall"), std::string::npos) << ruled.output;
  const auto a = testing::Summary(dir_ + "/alone"), r = testing::Summary(dir_ + "/ruled");
  EXPECT_EQ(a.at("bsf+filter").at("off_map_queries"), 48);
  EXPECT_GE(a.at("bsf+filter").at("off_map_accepted"), 4);
  EXPECT_LE(r.at("bsf+filter").at("off_map_accepted"), 1) << ruled.output;
  EXPECT_NEAR(r.at("bsf+filter").at("auc"), a.at("bsf+filter").at("auc"), 1e-12);
  EXPECT_GE(right(dir_ + "/ruled"), right(dir_ + "/alone") - 3) << ruled.output;
}

}  // namespace
}  // namespace bsf_vpr
