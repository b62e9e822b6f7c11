// The map of sets held in this process, through the plain interface the fusion node uses
// (map_backend.h), without ROS: load and unload from a data directory, a query's distances and
// the layout it is for, refusals that leave the sets as they were, a shard's answer.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "bsf_vpr/evaluation/synthetic.h"
#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/local_map.h"

namespace bsf_vpr {
namespace {

namespace fs = std::filesystem;

// A set of `n` places of dimension 4, row k = (k, 1, 0, 0) + offset.
ReferenceSet MakeSet(const std::string& name, int n, float offset) {
  ReferenceSet set;
  set.name = name;
  set.descriptors = RowMatrixXf::Zero(n, 4);
  for (int k = 0; k < n; ++k) {
    set.descriptors(k, 0) = static_cast<float>(k) + offset;
    set.descriptors(k, 1) = 1.0f;
    set.place_ids.push_back(k);
  }
  return set;
}

struct MapFixture : ::testing::Test {
  void SetUp() override {
    root = fs::temp_directory_path() /
           ("bsf_local_map_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root);
    dir = std::make_unique<DataDirectory>(root.string(), /*create=*/true);
    SaveReferenceSet(*dir, MakeSet("summer", 5, 0.0f), "summer.yaml", false);
    SaveReferenceSet(*dir, MakeSet("winter", 5, 0.25f), "winter.yaml", false);
    LocalMapOptions options;
    options.log = [this](LogLevel, const std::string& m) { log.push_back(m); };
    map = std::make_unique<LocalMap>(options, dir.get());
  }
  void TearDown() override {
    map.reset();
    fs::remove_all(root);
  }
  // The query of descriptor `d` through the interface.
  MapBackend::Query Ask(const std::vector<float>& d, uint32_t sec = 7) {
    QueryDescriptor q;
    q.header.sec = sec;
    q.header.frame_id = "camera";
    q.values = d.data();
    q.size = static_cast<Eigen::Index>(d.size());
    return map->Ask(q);
  }

  fs::path root;
  std::unique_ptr<DataDirectory> dir;
  std::unique_ptr<LocalMap> map;
  std::vector<std::string> log;
};

TEST_F(MapFixture, LoadsAsksAndUnloadsThroughThePlainInterface) {
  const uint64_t empty = map->layout()->generation;
  EXPECT_EQ(map->layout()->num_sets(), 0);
  EXPECT_EQ(map->Load({"summer.yaml", "", "", ""}, nullptr), "loaded 'summer' (5 places)");
  EXPECT_EQ(map->Load({"winter.yaml", "", "night", ""}, nullptr), "loaded 'winter' (5 places)");
  const MapBackend::Layout layout = map->layout();
  EXPECT_GT(layout->generation, empty);
  ASSERT_EQ(layout->num_sets(), 2);

  const MapBackend::Query q = Ask({2.0f, 1.0f, 0.0f, 0.0f});
  EXPECT_EQ(q.header.sec, 7u);
  EXPECT_EQ(q.header.frame_id, "camera");
  EXPECT_EQ(q.layout, layout);  // the layout the distances are for
  ASSERT_EQ(q.distances.num_sets(), 2);
  const RowMatrixXf& summer = q.distances.of(0);
  ASSERT_EQ(summer.cols(), 5);
  EXPECT_FLOAT_EQ(summer(0, 2), 0.0f);  // the same descriptor as summer's place 2
  EXPECT_FLOAT_EQ(summer(0, 0), 2.0f);
  EXPECT_FLOAT_EQ(q.distances.of(1)(0, 2), 0.25f);

  const SetList list = map->List();
  ASSERT_EQ(list.sets.size(), 2u);
  EXPECT_EQ(list.num_places, 5);
  EXPECT_EQ(list.sets[1].layout.name, "winter");
  EXPECT_EQ(list.sets[1].layout.condition, "night");
  EXPECT_EQ(list.sets[1].layout.dimension, 4);
  EXPECT_EQ(list.sets[1].storage, "float32");

  EXPECT_EQ(map->Unload("summer"), "unloaded 'summer'");
  EXPECT_GT(map->layout()->generation, layout->generation);
  EXPECT_EQ(map->List().sets.size(), 1u);
  EXPECT_EQ(q.layout->num_sets(), 2);  // a layout never changes once made
}

// The map calibrates itself in the background for the request in force: each query then
// carries the rule, List() and Diagnose() say what the map predicts, and the last rule
// answers while a change of sets is calibrated again.
TEST_F(MapFixture, TheMapCalibratesItselfInTheBackgroundAndQueriesCarryItsRule) {
  SyntheticOptions opt;  // three traversals of 120 places (synthetic: the mechanics)
  opt.num_places = 120;
  opt.dimension = 16;
  const SyntheticData data = GenerateMultiConditionData(opt);
  for (int u = 0; u < 2; ++u) map->Add(data.map.set(u).ToReferenceSet(), "synthetic");
  const std::vector<float> q(data.queries.row(3).data(), data.queries.row(3).data() + 16);
  EXPECT_FALSE(Ask(q).acceptance_rule);  // none asked for
  EXPECT_NE(map->List().calibration.find("none asked for"), std::string::npos);
  map->SetCalibration(CalibrationRequest{"bsf+filter", MethodOptions(), 0.05});
  map->WaitForCalibration();
  const std::optional<AcceptanceRule> rule = Ask(q).acceptance_rule;
  ASSERT_TRUE(rule) << map->List().calibration;
  EXPECT_NE(map->List().calibration.find("on this map (bsf+filter): false acceptances"),
            std::string::npos)
      << map->List().calibration;
  bool diagnosed = false;
  for (const auto& [key, value] : map->Diagnose()) {
    diagnosed |= key == "calibration" && value.find("at recall") != std::string::npos;
  }
  EXPECT_TRUE(diagnosed);
  // The same request again is nothing new; another keeps the last rule answering meanwhile.
  map->SetCalibration(CalibrationRequest{"bsf+filter", MethodOptions(), 0.05});
  EXPECT_EQ(map->List().calibration.find("calibrating"), std::string::npos);
  map->SetCalibration(CalibrationRequest{"bsf+filter", MethodOptions(), 0.1});
  EXPECT_TRUE(Ask(q).acceptance_rule);
  map->WaitForCalibration();
  EXPECT_TRUE(Ask(q).acceptance_rule);
  // A set added: the rule answers on while the three traversals are calibrated.
  map->Add(data.map.set(2).ToReferenceSet(), "synthetic");
  EXPECT_TRUE(Ask(q).acceptance_rule);
  map->WaitForCalibration();
  EXPECT_NE(map->List().calibration.find("on 360 held-out traversal rows"), std::string::npos)
      << map->List().calibration;
  // One traversal left: measured, not applied.
  map->Unload("c0");
  map->Unload("c1");
  map->WaitForCalibration();
  EXPECT_FALSE(Ask(q).acceptance_rule);
  EXPECT_NE(map->List().calibration.find("one traversal"), std::string::npos)
      << map->List().calibration;
  map->SetCalibration(std::nullopt);
  EXPECT_FALSE(Ask(q).acceptance_rule);
}

TEST_F(MapFixture, RefusalsNameTheProblemAndLeaveTheSetsAsTheyWere) {
  map->Load({"summer.yaml", "", "", ""}, nullptr);
  const MapBackend::Layout before = map->layout();
  const auto refused = [&](const std::function<void()>& f, const std::string& words) {
    try {
      f();
      ADD_FAILURE() << "not refused: " << words;
    } catch (const std::exception& e) {  // a file that cannot be read: std::runtime_error
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    EXPECT_EQ(map->layout(), before);
  };
  refused([&] { map->Load({"missing.yaml", "", "", ""}, nullptr); }, "missing.yaml");
  refused([&] { map->Load({"../outside.yaml", "", "", ""}, nullptr); }, "outside");
  refused([&] { map->Load({"winter.yaml", "", "", "shard_1"}, nullptr); }, "fuses no shards");
  refused(
      [&] {
        map->Load({"winter.yaml", "", "", ""},
                  [](const std::string& name) { throw std::invalid_argument(name + " taken"); });
      },
      "winter taken");
  refused([&] { map->Unload("autumn"); }, "no reference set named");
  refused([&] { Ask({1.0f, 2.0f}); }, "dimension");
  EXPECT_EQ(map->List().sets.size(), 1u);
}

TEST_F(MapFixture, ASetMeantForAnotherDistanceIsRefused) {
  LocalMapOptions options;
  options.metric = DistanceMetric::kCosine;
  LocalMap cosine(options, dir.get());
  try {
    ReferenceSet set = MakeSet("euclidean_set", 3, 0.0f);
    set.distance = "euclidean";
    cosine.Add(set, "recorded");
    ADD_FAILURE() << "a set meant for another distance was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("meant for euclidean"), std::string::npos) << e.what();
  }
  EXPECT_EQ(cosine.layout()->num_sets(), 0);
}

TEST_F(MapFixture, AShardsAnswerCarriesEverySetWithItsFingerprint) {
  LocalMapOptions options;
  options.fingerprints = true;
  options.log = [this](LogLevel, const std::string& m) { log.push_back(m); };
  LocalMap shard(options, dir.get(), "/shard_0");
  shard.LoadConfigured(
      {{(root / "summer.yaml").string(), "", ""}, {(root / "winter.yaml").string(), "", "snow"}});
  const std::vector<float> d = {1.0f, 1.0f, 0.0f, 0.0f};
  QueryDescriptor q;
  q.values = d.data();
  q.size = 4;
  const ShardAnswer a = shard.Answer(q);
  EXPECT_EQ(a.error, "");
  ASSERT_EQ(a.set_names, (std::vector<std::string>{"summer", "winter"}));
  ASSERT_EQ(a.fingerprints.size(), 2u);
  EXPECT_NE(a.fingerprints[0], 0u);
  EXPECT_NE(a.fingerprints[0], a.fingerprints[1]);
  EXPECT_FLOAT_EQ(a.distances[0](0, 1), 0.0f);
  std::vector<uint64_t> visited;
  shard.ForEachSet([&](const StoredReferenceSet& s, uint64_t f) {
    visited.push_back(f);
    if (s.name() == "winter") EXPECT_EQ(s.condition(), "snow");
  });
  EXPECT_EQ(visited, a.fingerprints);
  const std::vector<float> wrong = {1.0f};
  q.values = wrong.data();
  q.size = 1;
  const ShardAnswer refused = shard.Answer(q);
  EXPECT_NE(refused.error, "");
  EXPECT_TRUE(refused.set_names.empty());
  EXPECT_TRUE(refused.distances.empty());
  EXPECT_EQ(shard.Diagnose().size(), 3u);  // joint representation, first stage, calibration
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log[0], "loaded reference set 'summer' (5 places, dimension 4, float32)");
}

TEST_F(MapFixture, AskingWhileSetsLoadAndUnloadGivesEachQueryTheLayoutItWasComputedFor) {
  map->Load({"summer.yaml", "", "", ""}, nullptr);
  std::atomic<bool> stop{false};
  std::thread changer([&] {
    while (!stop) {
      map->Load({"winter.yaml", "", "", ""}, nullptr);
      map->Unload("winter");
    }
  });
  for (int i = 0; i < 300; ++i) {
    const MapBackend::Query q = Ask({0.0f, 1.0f, 0.0f, 0.0f});
    ASSERT_EQ(q.distances.num_sets(), q.layout->num_sets());
  }
  stop = true;
  changer.join();
}

}  // namespace
}  // namespace bsf_vpr

namespace bsf_vpr {
namespace {

// `n` rows of dimension 256 near a 6-dimensional subspace chosen by `subspace` (plus a
// little noise): sets of different subspaces are fitted poorly by each other's bases.
RowMatrixXf SubspaceRows(int n, int subspace, uint64_t seed) {
  std::mt19937 rng(static_cast<uint32_t>(seed));
  std::normal_distribution<float> g;
  const auto random = [&](int r, int c, float scale) {
    RowMatrixXf m(r, c);
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = scale * g(rng);
    return m;
  };
  std::mt19937 basis_rng(static_cast<uint32_t>(1000 + subspace));
  RowMatrixXf factors(6, 256);
  for (Eigen::Index i = 0; i < factors.size(); ++i) factors.data()[i] = g(basis_rng);
  return random(n, 6, 1.0f) * factors + random(n, 256, 0.02f);
}

// Sets memory-mapped at int8 with the pca first stage built in the background: a query goes
// on with the index it has while a load's build runs (the new set absent from it), and the
// new index takes over when built; an unload answers at once with the codes held.
TEST_F(MapFixture, TheFirstStageIsBuiltInTheBackgroundWhileQueriesGoOn) {
  for (const auto& [name, rows, subspace] :
       {std::tuple{"near", 500, 1}, std::tuple{"far", 3000, 2}}) {
    ReferenceSets encoder;
    encoder.SetStoragePrecision(StoragePrecision::kInt8);
    encoder.Add(MakeReferenceSet(name, SubspaceRows(rows, subspace, 7)));
    SaveStoredReferenceSet(encoder.set(0), (root / (std::string(name) + ".yaml")).string());
  }
  LocalMapOptions options;
  options.storage = StoragePrecision::kInt8;
  options.memory_map = true;
  options.first_stage.kind = "pca";
  options.first_stage.approximate.dimensions = 16;
  options.first_stage.approximate.rerank = 5;
  // A basis fitted to 1024 rows: the refit below takes a fraction of a second, which is
  // still long after the query that follows the load (tests run under sanitizers too).
  options.first_stage.approximate.sample_rows = 1024;
  options.log = [this](LogLevel, const std::string& m) { log.push_back(m); };
  LocalMap m(options, dir.get());
  const std::vector<float> d = [] {
    const RowMatrixXf q = SubspaceRows(1, 1, 99);
    return std::vector<float>(q.data(), q.data() + q.size());
  }();
  QueryDescriptor q;
  q.values = d.data();
  q.size = static_cast<Eigen::Index>(d.size());

  EXPECT_EQ(m.Load({"near.yaml", "", "", ""}, nullptr), "loaded 'near' (500 places)");
  EXPECT_NE(m.List().sets.at(0).storage.find("memory-mapped"), std::string::npos);
  m.WaitForIndex();
  MapBackend::Query first = m.Ask(q);
  ASSERT_EQ(first.distances.num_sets(), 1);
  EXPECT_TRUE(first.distances.present(0));

  // "far" lies in another subspace: the basis of "near" keeps little of it, so the build
  // fits a new basis to both, during which "near" answers alone.
  EXPECT_EQ(m.Load({"far.yaml", "", "", ""}, nullptr), "loaded 'far' (3000 places)");
  const MapBackend::Query during = m.Ask(q);
  const std::string status = m.Diagnose().at(1).second;
  ASSERT_NE(status.find("building"), std::string::npos)
      << "the build ended before the query: " << status;
  ASSERT_EQ(during.distances.num_sets(), 2);
  EXPECT_TRUE(during.distances.present(0));
  EXPECT_FALSE(during.distances.present(1));
  EXPECT_EQ(during.layout->num_sets(), 2);
  m.WaitForIndex();
  const MapBackend::Query after = m.Ask(q);
  EXPECT_TRUE(after.distances.present(0));
  EXPECT_TRUE(after.distances.present(1));
  EXPECT_EQ(after.distances.of(1).cols(), 3000);
  EXPECT_NE(m.Diagnose().at(1).second.find("of 3500 rows"), std::string::npos)
      << m.Diagnose().at(1).second;
  bool refit = false;
  for (const std::string& line : log)
    refit = refit || line.find("a new basis (") != std::string::npos;
  EXPECT_TRUE(refit) << "the build kept a basis that fits 'far' poorly";

  // An unload needs no projection: the remaining set answers at once.
  EXPECT_EQ(m.Unload("near"), "unloaded 'near'");
  const MapBackend::Query unloaded = m.Ask(q);
  ASSERT_EQ(unloaded.distances.num_sets(), 1);
  EXPECT_TRUE(unloaded.distances.present(0));
  m.WaitForIndex();
  EXPECT_NE(m.Diagnose().at(1).second.find("of 3000 rows"), std::string::npos);
}

// The .npy file below `root` whose name starts with `stem` (a stored set's rows).
std::string RowsFile(const fs::path& root, const std::string& stem) {
  for (const auto& e : fs::directory_iterator(root)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(stem + ".", 0) == 0 && e.path().extension() == ".npy") return e.path().string();
  }
  return "";
}

// Found attacking the node: a memory-mapped set's file rewritten in place (cp over it, bytes
// written with dd conv=notrunc, truncate) changed the live map silently, or ended the process
// with SIGBUS. While queries run, each way: no query's distances come from the changed rows
// (every distance given for the set is the one its rows gave when loaded), the set is
// unloaded, and the log and Problem() name it and its file; truncation ends nothing.
TEST_F(MapFixture, AMappedFileRewrittenInPlaceIsDroppedAndNoQueryUsesItsNewRows) {
  constexpr int kRows = 2000;
  for (const char* how : {"copied over", "bytes in place", "truncated"}) {
    SCOPED_TRACE(how);
    ReferenceSets encoder;
    encoder.SetStoragePrecision(StoragePrecision::kInt8);
    encoder.Add(MakeReferenceSet("mapped", SubspaceRows(kRows, 1, 11)));
    encoder.Add(MakeReferenceSet("other", SubspaceRows(kRows, 2, 12)));
    SaveStoredReferenceSet(encoder.set(0), (root / "mapped.yaml").string());
    SaveStoredReferenceSet(encoder.set(1), (root / "other.yaml").string());
    LocalMapOptions options;
    options.storage = StoragePrecision::kInt8;
    options.memory_map = true;
    std::vector<std::string> messages;
    std::mutex messages_mutex;
    options.log = [&](LogLevel, const std::string& m) {
      std::lock_guard<std::mutex> lock(messages_mutex);
      messages.push_back(m);
    };
    LocalMap m(options, dir.get());
    m.Load({"mapped.yaml", "", "", ""}, nullptr);
    const RowMatrixXf q = SubspaceRows(1, 1, 99);
    QueryDescriptor d;
    d.values = q.data();
    d.size = q.size();
    const RowMatrixXf loaded = m.Ask(d).distances.of(0);

    std::atomic<bool> stop{false};
    std::atomic<int> present{0}, wrong{0}, absent{0};
    std::thread asker([&] {
      while (!stop) {
        MapBackend::Query a;
        try {
          a = m.Ask(d);
        } catch (const std::invalid_argument&) {
          ++absent;  // no set left to ask
          continue;
        }
        if (a.distances.num_sets() == 1 && a.distances.present(0)) {
          ++present;
          if (!(a.distances.of(0).array() == loaded.array()).all()) ++wrong;
        } else {
          ++absent;
        }
      }
    });
    while (present < 20) std::this_thread::yield();
    const std::string npy = RowsFile(root, "mapped");
    ASSERT_FALSE(npy.empty());
    const std::string other_npy = RowsFile(root, "other");
    if (std::string(how) == "copied over") {
      fs::copy_file(other_npy, npy, fs::copy_options::overwrite_existing);  // same size
    } else if (std::string(how) == "bytes in place") {
      std::fstream f(npy, std::ios::in | std::ios::out | std::ios::binary);
      f.seekp(static_cast<std::streamoff>(fs::file_size(npy) / 2));
      const std::string noise(4096 * 64, '\x55');
      f.write(noise.data(), static_cast<std::streamsize>(noise.size()));
    } else {
      ASSERT_EQ(::truncate(npy.c_str(), 100), 0);
    }
    const int before = present;
    // Queries go on after the change, without the set.
    const int after_change = absent + 20;
    while (absent < after_change) std::this_thread::yield();
    stop = true;
    asker.join();
    EXPECT_EQ(wrong, 0) << "of " << present << " queries with the set, " << wrong
                        << " used rows that changed";
    EXPECT_GE(before, 20);
    EXPECT_EQ(m.num_sets(), 0);
    EXPECT_NE(m.Problem().find("'mapped' was unloaded"), std::string::npos) << m.Problem();
    EXPECT_NE(m.Problem().find(npy.substr(root.string().size() + 1)), std::string::npos)
        << m.Problem();
    bool logged = false;
    for (const std::string& line : messages) {
      logged = logged || (line.find("reference set 'mapped' unloaded") != std::string::npos &&
                          line.find("mapped.") != std::string::npos);
    }
    EXPECT_TRUE(logged);
    // Loaded again, the file as it is now answers (or is refused, truncated).
    if (std::string(how) == "truncated") {
      EXPECT_THROW(m.Load({"mapped.yaml", "", "", ""}, nullptr), std::exception);
    } else {
      EXPECT_NO_THROW(m.Load({"mapped.yaml", "", "", ""}, nullptr));
      EXPECT_EQ(m.Problem(), "");
    }
    fs::remove(npy);
    fs::remove(root / "mapped.yaml");
    fs::remove(other_npy);
    fs::remove(root / "other.yaml");
  }
}

// With no index yet, a query is refused with the reason, not answered wrongly or waited on.
TEST_F(MapFixture, AQueryBeforeTheFirstIndexIsRefusedNamingTheBuild) {
  LocalMapOptions options;
  options.first_stage.kind = "pca";
  LocalMap m(options, dir.get());
  EXPECT_THROW(m.Ask(QueryDescriptor()), std::invalid_argument);  // no set: the usual refusal
  m.LoadConfigured({{(root / "summer.yaml").string(), "", ""}});
  const std::vector<float> d = {1.0f, 1.0f, 0.0f, 0.0f};
  QueryDescriptor q;
  q.values = d.data();
  q.size = 4;
  try {
    m.Ask(q);  // the first build may already be done: then it answers
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("the first stage's index is being built"),
              std::string::npos)
        << e.what();
  }
  m.WaitForIndex();
  EXPECT_TRUE(m.Ask(q).distances.present(0));
}

}  // namespace
}  // namespace bsf_vpr
