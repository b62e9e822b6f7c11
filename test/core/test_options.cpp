// The options tables: one declaration per option gives the defaults, the flags, the checks
// and the usage text; every table entry reads and writes its own member.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "bsf_vpr/core/descriptor_store.h"
#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/first_stage.h"
#include "bsf_vpr/core/fusion.h"
#include "bsf_vpr/core/likelihood.h"
#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/core/options.h"
#include "bsf_vpr/core/place_index.h"
#include "bsf_vpr/core/recognizer_options.h"
#include "bsf_vpr/core/reference_recorder.h"
#include "bsf_vpr/core/selection.h"
#include "bsf_vpr/image/image_describer.h"
#include "test/core/enum_names_check.h"

namespace bsf_vpr {
namespace {

// A valid value of `info` that differs from its default.
OptionValue OtherValue(const OptionInfo& info) {
  const OptionValue& d = info.default_value;
  switch (info.type) {
    case OptionType::kBool:
      return !std::get<bool>(d);
    case OptionType::kInt: {
      const long long v = std::get<long long>(d);
      return v + 1 <= info.bounds.max ? v + 1 : v - 1;
    }
    case OptionType::kDouble: {
      const double v = std::get<double>(d);
      const double up = v + 0.125;
      if (up < info.bounds.max) return up;
      return v - 0.125 > info.bounds.min ? v - 0.125 : (v + info.bounds.min) / 2;
    }
    case OptionType::kChoice:
      for (const std::string& c : info.choices) {
        if (c != std::get<std::string>(d)) return c;
      }
      break;
    case OptionType::kDoubleList: {
      std::vector<double> v = std::get<std::vector<double>>(d);
      v.push_back(0.5);
      return v;
    }
    case OptionType::kString:
      return std::get<std::string>(d) + "x";
    case OptionType::kExternal:
      break;
  }
  ADD_FAILURE() << info.name << " has no other value";
  return d;
}

// Setting one option through a source changes that option and no other: each entry is
// wired to its own member, and the default is the struct's.
template <typename S>
void ExpectEachOptionOwnsItsMember(const OptionTable<S>& table) {
  const S defaults{};
  std::set<std::string> names;
  for (const auto& spec : table.specs()) {
    EXPECT_TRUE(names.insert(spec.info.name).second) << "twice: " << spec.info.name;
    if (!spec.get) continue;
    EXPECT_EQ(spec.get(defaults), spec.info.default_value) << spec.info.name;
    const OptionValue other = OtherValue(spec.info);
    NamedValueSource source({{spec.info.name, other}});
    S changed{};
    table.Apply(source, &changed);
    EXPECT_TRUE(source.Unread().empty());
    for (const auto& [name, value] : table.Values(changed)) {
      if (name == spec.info.name) {
        EXPECT_EQ(value, other) << name;
      } else {
        EXPECT_EQ(value, table.Find(name)->info.default_value)
            << "setting " << spec.info.name << " changed " << name;
      }
    }
    // The same through its command-line flag.
    S flagged{};
    ASSERT_TRUE(table.SetFromFlag(OptionFlag(spec.info.name), FormatOptionValue(other), &flagged))
        << spec.info.name;
    EXPECT_EQ(spec.get(flagged), other) << spec.info.name;
  }
}

TEST(Options, EveryTableEntryOwnsItsMember) {
  ExpectEachOptionOwnsItsMember(MethodOptionsTable());
  ExpectEachOptionOwnsItsMember(RecognizerOptionsTable());
  ExpectEachOptionOwnsItsMember(ImageDescriberOptionsTable());
}

TEST(Options, OneDefaultThresholdEverywhere) {
  // The core, bsf_evaluate and the node share the struct's default (it was 0.5 in the
  // core and the evaluator but 0.9 in the node).
  const OptionInfo& info = MethodOptionsTable().Find("threshold")->info;
  EXPECT_EQ(info.default_value, OptionValue(0.9));
  EXPECT_EQ(MethodOptions().decision.threshold.value, 0.9);
  EXPECT_EQ(MethodOptionsTable().Find("threshold_kind")->info.default_value,
            OptionValue(std::string("probability")));
}

TEST(Options, FlagsTakeDashesOrUnderscores) {
  MethodOptions o;
  EXPECT_TRUE(MethodOptionsTable().SetFromFlag("--gamma-fraction", "0.25", &o));
  EXPECT_EQ(o.selection.gamma_fraction, 0.25);
  EXPECT_TRUE(MethodOptionsTable().SetFromFlag("--gamma_fraction", "0.5", &o));
  EXPECT_EQ(o.selection.gamma_fraction, 0.5);
  EXPECT_TRUE(MethodOptionsTable().SetFromFlag("--sequence-use-partial", "false", &o));
  EXPECT_FALSE(o.sequence.use_partial_sequences);
  EXPECT_TRUE(MethodOptionsTable().SetFromFlag("--threshold-kind", "log_odds", &o));
  EXPECT_EQ(o.decision.threshold.kind, Threshold::Kind::kLogOdds);
  EXPECT_FALSE(MethodOptionsTable().SetFromFlag("--gamma", "0.5", &o));  // not an option
  EXPECT_FALSE(MethodOptionsTable().SetFromFlag("gamma_fraction", "0.5", &o));
  EXPECT_EQ(o.selection.gamma_fraction, 0.5);
}

void ExpectThrowsWith(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no exception; expected one with '" << part << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(Options, BadValuesNameTheOptionAndChangeNothing) {
  const auto& t = MethodOptionsTable();
  MethodOptions o;
  ExpectThrowsWith([&] { t.SetFromFlag("--gamma-fraction", "-1", &o); },
                   "--gamma-fraction must be >= 0, got -1");
  ExpectThrowsWith([&] { t.SetFromFlag("--gamma-fraction", "abc", &o); },
                   "--gamma-fraction expects a number, got 'abc'");
  ExpectThrowsWith([&] { t.SetFromFlag("--relocalization-probability", "0", &o); },
                   "must be in (0, 1]");
  ExpectThrowsWith([&] { t.SetFromFlag("--selection", "best", &o); },
                   "--selection must be relative | standardized, got 'best'");
  ExpectThrowsWith([&] { t.SetFromFlag("--top-k", "2.5", &o); }, "expects a whole number");
  ExpectThrowsWith([&] { t.SetFromFlag("--top-k", "99999999999", &o); }, "out of range");
  ExpectThrowsWith([&] { t.SetFromFlag("--sequence-use-partial", "yes", &o); },
                   "expects true or false");
  ExpectThrowsWith([&] { t.SetFromFlag("--filter-step-mean-places", "nan", &o); },
                   "--filter-step-mean-places");
  EXPECT_EQ(o.selection.gamma_fraction, MethodOptions().selection.gamma_fraction);
  EXPECT_EQ(o.decision.top_k, MethodOptions().decision.top_k);
}

TEST(Options, SourcesAreTypedAndTracked) {
  NamedValueSource source({{"gamma_fraction", 1LL},  // a whole number for a double: fine
                          {"top_k", 3.5},           // a double for an int: refused
                          {"unheard_of", true}},
                         "/bsf_vpr/");
  MethodOptions o;
  ExpectThrowsWith([&] { MethodOptionsTable().Apply(source, &o); },
                   "/bsf_vpr/top_k must be a whole number, got '3.5'");
  EXPECT_EQ(o.selection.gamma_fraction, 1.0);
  EXPECT_EQ(source.Unread(), std::vector<std::string>{"unheard_of"});
}

TEST(Options, LiveOnlyLeavesTheOthers) {
  NamedValueSource source({{"top_k", 3LL}, {"threshold", 0.5}});
  MethodOptions o;
  MethodOptionsTable().Apply(source, &o, /*live_only=*/true);
  EXPECT_EQ(o.decision.top_k, MethodOptions().decision.top_k);  // top_k is not live
  EXPECT_EQ(o.decision.threshold.value, 0.5);
  for (const OptionInfo& info : MethodOptionsTable().Infos(/*live_only=*/true)) {
    EXPECT_TRUE(info.live) << info.name;
  }
}

TEST(Options, UsageListsEveryFlagWithItsDefault) {
  const std::string usage = OptionsUsage(MethodOptionsTable().Infos());
  for (const OptionInfo& info : MethodOptionsTable().Infos()) {
    EXPECT_NE(usage.find(OptionFlag(info.name)), std::string::npos) << info.name;
  }
  EXPECT_NE(usage.find("default 0.04"), std::string::npos) << usage;
  EXPECT_NE(usage.find("relative | standardized"), std::string::npos) << usage;
  for (size_t start = 0, end; start < usage.size(); start = end + 1) {
    end = usage.find('\n', start);
    EXPECT_LE(end - start, 92u) << usage.substr(start, end - start);
  }
}

TEST(Options, FormatsValuesAsUsersWriteThem) {
  EXPECT_EQ(FormatOptionValue(0.04), "0.04");
  EXPECT_EQ(FormatOptionValue(1.0), "1.0");
  EXPECT_EQ(FormatOptionValue(1e-9), "1e-09");
  EXPECT_EQ(FormatOptionValue(12LL), "12");
  EXPECT_EQ(FormatOptionValue(std::vector<double>{0.5, 2}), "0.5,2.0");
  EXPECT_EQ(OptionFlag("filter_step_mean_places"), "--filter-step-mean-places");
  EXPECT_EQ(OptionNameFromFlag("--filter-step_mean-places"), "filter_step_mean_places");
}

// Each enumeration's names are written once (EnumNames) and read by its Parse and ToString
// functions and by the option tables.
TEST(Options, EveryEnumerationsNamesRoundTrip) {
  using testing::ExpectNamesRoundTrip;
  ExpectNamesRoundTrip(DistanceMetricNames(), ParseDistanceMetric, "distance");
  ExpectNamesRoundTrip(StoragePrecisionNames(), ParseStoragePrecision, "storage");
  ExpectNamesRoundTrip(ThresholdKindNames(), ParseThresholdKind, "threshold_kind");
  ExpectNamesRoundTrip(FusionRuleNames(), ParseFusionRule, "fusion");
  ExpectNamesRoundTrip(LikelihoodVariantNames(), ParseLikelihoodVariant, "likelihood");
  ExpectNamesRoundTrip(SelectionRuleNames(), ParseSelectionRule, "selection");
  ExpectNamesRoundTrip(RecordingPlacesNames(), ParseRecordingPlaces, "places");
  ExpectNamesRoundTrip(ImageDescriberKindNames(), ParseImageDescriberKind, "image_descriptor");
  ExpectNamesRoundTrip<FirstStageKind>(FirstStageKindNames(), nullptr, "first_stage");
  for (const auto& [kind, name] : FirstStageKindNames().entries()) {
    FirstStageOptions o;
    o.kind = name;
    EXPECT_EQ(o.Kind(), kind);
    EXPECT_EQ(ToString(kind), name);
  }
  FirstStageOptions pq;
  pq.kind = "pq";
  ExpectThrowsWith([&] { pq.Kind(); }, "first_stage must be exact or pca, got 'pq'");
  ExpectThrowsWith([&] { pq.Validate(); }, "first_stage must be exact | pca, got 'pq'");
}

// The first stage's kind is parsed when the options are set, not compared as text per query.
TEST(Options, TheDistanceStageKeepsTheParsedKind) {
  DistanceStage stage;
  EXPECT_EQ(stage.kind(), FirstStageKind::kExact);
  FirstStageOptions o;
  o.kind = "pca";
  stage.SetOptions(o);
  EXPECT_EQ(stage.kind(), FirstStageKind::kPca);
  o.kind = "pq";
  EXPECT_THROW(stage.SetOptions(o), std::invalid_argument);
  EXPECT_EQ(stage.kind(), FirstStageKind::kPca);  // the options in force are kept
  EXPECT_EQ(stage.options().kind, "pca");
}

// A table's choices are the names, in their order, and a value reads and writes through them.
TEST(Options, ChoicesAreTheEnumerationsNames) {
  EXPECT_EQ(MethodOptionsTable().Find("fusion")->info.choices, FusionRuleNames().Choices());
  EXPECT_EQ(MethodOptionsTable().Find("likelihood")->info.choices,
            (std::vector<std::string>{"one_sided", "two_sided"}));
  EXPECT_EQ(RecognizerOptionsTable().Find("first_stage")->info.choices,
            (std::vector<std::string>{"exact", "pca"}));
  MethodOptions o;
  o.likelihood.variant = LikelihoodVariant::kTwoSided;
  EXPECT_EQ(MethodOptionsTable().Find("likelihood")->get(o), OptionValue(std::string("two_sided")));
  EXPECT_TRUE(MethodOptionsTable().SetFromFlag("--fusion", "product", &o));
  EXPECT_EQ(o.fusion, FusionRule::kProduct);
}

// A value just out of `info`'s bounds on the side `below` (nullopt: the bounds are open there).
std::optional<OptionValue> OutOfBounds(const OptionInfo& info, bool below) {
  const OptionBounds& b = info.bounds;
  const double edge = below ? b.min : b.max;
  if (!std::isfinite(edge)) return std::nullopt;
  const bool open = below ? b.min_open : b.max_open;
  if (info.type == OptionType::kInt) return static_cast<long long>(edge) + (below ? -1 : 1);
  if (info.type == OptionType::kDouble) return open ? edge : edge + (below ? -0.5 : 0.5);
  return std::nullopt;
}

// Every bound of `table` is enforced by `validate` for options built in code (a value put in
// the member, not read through the table), and the message names the option.
template <typename S, typename Validate>
void ExpectValidateEnforcesTheBounds(const OptionTable<S>& table, const S& valid,
                                     Validate validate) {
  EXPECT_NO_THROW(validate(valid));
  for (const auto& spec : table.specs()) {
    if (!spec.set) continue;
    std::vector<OptionValue> bad;
    for (bool below : {true, false}) {
      if (const std::optional<OptionValue> v = OutOfBounds(spec.info, below)) bad.push_back(*v);
    }
    if (spec.info.bounds.finite) bad.push_back(std::numeric_limits<double>::infinity());
    for (const OptionValue& v : bad) {
      S options = valid;
      spec.set(options, v);
      ExpectThrowsWith([&] { validate(options); }, spec.info.name + " must be");
    }
  }
}

TEST(Options, ValidateEnforcesTheTableBoundsOfOptionsBuiltInCode) {
  ExpectValidateEnforcesTheBounds(MethodOptionsTable(), MethodOptions(),
                                  [](const MethodOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(RecognizerOptionsTable(), RecognizerOptions(),
                                  [](const RecognizerOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(SequenceOptionsTable(), SequenceOptions(),
                                  [](const SequenceOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(TemporalFilterOptionsTable(), TemporalFilterOptions(),
                                  [](const TemporalFilterOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(PlaceIndexOptionsTable(), PlaceIndexOptions(),
                                  [](const PlaceIndexOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(PatchNormOptionsTable(), PatchNormOptions(),
                                  [](const PatchNormOptions& o) { o.Validate(); });
  ExpectValidateEnforcesTheBounds(HogOptionsTable(), HogOptions(),
                                  [](const HogOptions& o) { o.Validate(); });
  OnnxOptions onnx;
  onnx.model_path = "model.onnx";  // read by MakeImageDescriber, not by Validate
  ExpectValidateEnforcesTheBounds(OnnxOptionsTable(), onnx,
                                  [](const OnnxOptions& o) { o.Validate(); });

  // The messages say what the bound is and what came.
  MethodOptions o;
  o.sequence.length = kMaxSequenceLength + 1;
  ExpectThrowsWith([&] { o.Validate(); }, "sequence_length must be in [1, 1000], got 1001");
  o = MethodOptions();
  o.selection.gamma_fraction = std::numeric_limits<double>::infinity();
  ExpectThrowsWith([&] { o.Validate(); }, "gamma_fraction must be a finite number >= 0, got inf");
  o = MethodOptions();
  o.filter.step_mean_places = std::nan("");
  ExpectThrowsWith([&] { o.filter.Validate(); },
                   "filter_step_mean_places must be a finite number, got nan");
  // NaN names the range, also where the table has none to say ("threshold must be , got
  // nan" before).
  o = MethodOptions();
  o.decision.threshold.value = std::nan("");
  ExpectThrowsWith([&] { o.Validate(); }, "threshold must be a finite number, got nan");
  OptionInfo free;
  free.name = "free";
  free.type = OptionType::kDouble;
  ExpectThrowsWith([&] { CheckOptionValue(free, std::nan(""), "free"); },
                   "free must be a number, got nan");
  OptionInfo bounded = free;
  bounded.bounds = AtLeast(2);
  ExpectThrowsWith([&] { CheckOptionValue(bounded, std::nan(""), "b"); },
                   "b must be a number >= 2, got nan");
  // Rules across fields stay in Validate().
  o = MethodOptions();
  o.sequence.min_velocity = 2;
  o.sequence.max_velocity = 1;
  ExpectThrowsWith([&] { o.Validate(); }, "sequence_min_velocity <= sequence_max_velocity");
  // ApproximateOptions are named by their fields (the index is built in code).
  ApproximateOptions a;
  a.sample_rows = ApproximateOptions::kMaxSampleRows + 1;
  ExpectThrowsWith([&] { a.Validate(); }, "ApproximateOptions.sample_rows must be in [1, 8192]");
}

}  // namespace
}  // namespace bsf_vpr
