// bsf_benchmark: speed and memory of bsf_vpr against baselines measured in the same run
// (see --help and docs/performance.md). Every figure is the median of --repeats runs.
#include <cblas.h>
#include <faiss/IndexFlat.h>
#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "bsf_vpr/core/method_runner.h"
#include "bsf_vpr/evaluation/evaluation_runner.h"
#include "bsf_vpr/map/place_recognizer.h"
#include "src/tools/benchmark/benchmark_describe.h"
#include "src/tools/benchmark/benchmark_evaluate.h"
#include "src/tools/benchmark/benchmark_fusion.h"
#include "src/tools/benchmark/benchmark_joint.h"
#include "src/tools/benchmark/benchmark_large.h"
#include "src/tools/benchmark/benchmark_mapped.h"
#include "src/tools/benchmark/benchmark_off_map.h"
#include "src/tools/benchmark/benchmark_util.h"
#include "src/tools/benchmark/cpu_baseline.h"
#include "src/tools/benchmark/naive_bsf.h"
#include "src/tools/common/cli_util.h"

namespace {

using namespace bsf_vpr;
using tools::AvailableBytes;
using tools::InterleavedTimesMs;
using tools::Median;
using tools::MedianRatio;
using tools::ResidentBytes;
using tools::TimeMs;

const char kUsage[] =
    R"(usage: bsf_benchmark [--sections LIST] [--repeats R] [--storage P] [--evaluate-dir DIR]
                     [--images DIR] [--first-stage-dimensions D] [--rerank-candidates K]
                     [--first-stage-sample-rows S] [--mapped-dir DIR] [--quick]

Baselines use as many threads as bsf_vpr does (the machine's cores): the streaming probe
and the GEMM probe (OpenBLAS sgemm). The first line names the CPU, its vector extensions and
OpenBLAS's kernel: when OpenBLAS does not know the CPU and falls back to a narrower kernel
(Debian 12's 0.3.21 runs Prescott, SSE3, on Intel Xeons of 2023), the benchmark runs again
with OPENBLAS_CORETYPE set to the kernel that fits the CPU's vector width (SkylakeX for
AVX-512, Haswell for AVX2), for itself and the NumPy baselines; an OPENBLAS_CORETYPE given
by the caller is kept, and flagged "NOT FAIR" when it is narrower than the CPU (some hosts
set Haswell on AVX-512 CPUs: unset OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE for fair figures).

Measures, on random data of the stated shapes (float32), medians of R runs (default 7):
  fusion   selection + likelihoods + posterior for M=3, N=3000 given the distances:
           bsf_vpr vs the paper's formulas written straightforwardly (O(N^2))
  query    one query end to end (distances + fusion), M=3, N=3000, D=4096, with float32,
           float16 and int8 storage: vs the time to stream the same stored bytes once (the
           memory limit for one query), and the distance part vs FAISS IndexFlatL2 search
  batch    a whole offline evaluation of Q=500 queries against M=3, N=3000, D=4096 vs a
           matrix product (OpenBLAS sgemm) of the same shape
  evaluate bsf_evaluate end to end (3 .npy sets of 3000 x 4096, 3000 queries, --methods bsf,
           results written) vs scripts/numpy_bsf, the same method in NumPy + OpenBLAS, as
           separate processes on the same files (written once to --evaluate-dir DIR, default
           /tmp/bsf_benchmark_evaluate, 196 MB), for --fusion mixture and for the paper's
           method (--fusion product --likelihood two_sided); also the cores each kept busy,
           bsf_evaluate's phases and NumPy's distances alone
  describe per image (median and p90 over the images of --images DIR, default the shipped
           data/nordland_subset100/256x144/summer), at their resolution: decoding, and each
           image describer (patchnorm and hog with their defaults, onnx with the test models
           test/data/models/{resnet50_light,squeezenet_light}, 224x224 input) vs cv::resize
           of the same image to the describer's input size alone
  large    one query against M=10 sets of N=100,000 places, D=4096, int8 storage (4.1 GB of
           random data: time only), exact vs the pca first stage with re-ranking (its index's
           build time and memory too), and where a pca query's time goes: first stage,
           re-rank, decision, and of the decision the likelihoods timed apart
  scaling  time per query and resident memory for N in {1k,10k,100k}, M in {1,3,10},
           D in {256,1024,4096} (combinations needing over 3/4 of the memory available are
           skipped), with the references stored at --storage float32|float16|int8 (default
           float32); exact, and for D above the first stage's d' also the pca first stage
           (time per query, its index's build time and memory; random data: time only)
  joint    the joint representation of the sets: a query of the default bsf (with the
           discriminant) vs without it (fusion_joint none), M=3, N=3000, D=4096, timed in
           turn; the discriminant, mean and subspace built at that size; the discriminant
           built at M=10, N=100,000, D=4096 int8 (minutes; skipped without the memory)
  offmap   the hypothesis "no place of the map": a query of bsf and of bsf+filter with
           off_map (the default) vs without, M=3, N=3000, D=4096, timed in turn
  mapped   sets memory-mapped (int8 .npy as bsf_store_set writes them; M=11 sets of
           N=100,000 x 4096 random rows written once to --mapped-dir DIR, default
           /tmp/bsf_benchmark_mapped, 4.5 GB): opening one set mapped vs read into memory
           (from the disk, its pages evicted, and from the page cache); the map of 10 sets
           through the fusion node's map with the pca first stage: its index built in the
           background, a query's time, resident memory; then the 11th set loaded while
           queries stream back to back, and every query's delay meanwhile
The large and scaling sections take the pca first stage's options as bsf_evaluate and the
fusion node do (defaults: d' = 256, 1000 re-ranked per set, basis from 2048 rows):
  --first-stage-dimensions D, --rerank-candidates K, --first-stage-sample-rows S
--sections takes a comma-separated subset (default: all). --quick shrinks the shapes by 10x
(describe: the first 10 images) and the scaling grid by 100x (a smoke test; its figures are
not the documented ones).
The figures are printed on standard output, a line per measurement; no file is written.
  -h, --help             this help
Exit status 2 with one line naming the problem on bad arguments.
)";

RowMatrixXf Random(Eigen::Index rows, Eigen::Index cols, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  RowMatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = normal(rng);
  return m;
}

volatile float g_sink;  // keeps the probes from being optimised away

struct Shape {
  int m, n, d;
};

PlaceRecognizer MakeRecognizer(const Shape& s, uint64_t seed,
                               StoragePrecision storage = StoragePrecision::kFloat32) {
  PlaceRecognizer r(RecognizerOptions(), storage);
  for (int u = 0; u < s.m; ++u) {
    r.AddReferenceSet(MakeReferenceSet("s" + std::to_string(u), Random(s.n, s.d, seed + u)));
  }
  return r;
}

// The same sets, for the baselines that read the rows (and the evaluator, which holds them).
ReferenceSets MakeSets(const Shape& s, uint64_t seed) {
  ReferenceSets map;
  for (int u = 0; u < s.m; ++u) {
    map.Add(MakeReferenceSet("s" + std::to_string(u), Random(s.n, s.d, seed + u)));
  }
  return map;
}

// The rows of a set stored at float32 (what the float32 baselines read in place).
const float* Float32Rows(const StoredReferenceSet& set) {
  if (set.precision() != StoragePrecision::kFloat32) {
    throw std::logic_error("the float32 baselines need a set stored at float32");
  }
  return static_cast<const float*>(set.data());
}

// XOR-folds 64-bit words [w0, w1) into independent accumulators: far more work per byte
// than memory delivers, so memory is the limit. The AVX2 build reads 32 bytes a load, as
// the distance kernel does; the portable one whatever the compiler vectorises.
uint64_t FoldWordsPortable(const uint64_t* p, size_t w0, size_t w1) {
  uint64_t acc[8] = {};
  size_t w = w0;
  for (; w + 8 <= w1; w += 8) {
    for (int k = 0; k < 8; ++k) acc[k] ^= p[w + k];
  }
  for (; w < w1; ++w) acc[0] ^= p[w];
  uint64_t x = 0;
  for (uint64_t a : acc) x ^= a;
  return x;
}

#if defined(__x86_64__)
// Eight streams at once (the range cut in eight), as the kernel reads several rows at once:
// more reads in flight than one sequential stream gets.
__attribute__((target("avx2"))) uint64_t FoldWordsAvx2(const uint64_t* p, size_t w0, size_t w1) {
  typedef long long Vec4 __attribute__((vector_size(32), aligned(1)));
  constexpr int kStreams = 8;
  const size_t part = (w1 - w0) / kStreams / 4 * 4;  // words per stream, whole vectors
  Vec4 acc[kStreams] = {};
  for (size_t j = 0; j < part; j += 4) {
    for (int s = 0; s < kStreams; ++s) {
      acc[s] ^= *reinterpret_cast<const Vec4*>(p + w0 + s * part + j);
    }
  }
  Vec4 a = {};
  for (const Vec4& x : acc) a ^= x;
  return static_cast<uint64_t>(a[0] ^ a[1] ^ a[2] ^ a[3]) ^
         FoldWordsPortable(p, w0 + kStreams * part, w1);
}
#endif

uint64_t FoldWords(const uint64_t* p, size_t w0, size_t w1) {
#if defined(__x86_64__)
  if (DistanceKernel() != "portable") return FoldWordsAvx2(p, w0, w1);
#endif
  return FoldWordsPortable(p, w0, w1);
}

// Memory-bandwidth probe: reads every stored byte of the map once, split over `threads` as
// the distances are.
uint64_t StreamOnce(const ReferenceSets& map, int threads) {
  std::vector<uint64_t> partial(static_cast<size_t>(threads), 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&, t] {
      for (const StoredReferenceSet& set : map.sets()) {
        const size_t words = set.data_bytes() / 8;
        const auto* data = static_cast<const uint64_t*>(set.data());
        partial[static_cast<size_t>(t)] ^=
            FoldWords(data, words * t / threads, words * (t + 1) / threads);
      }
    });
  }
  for (std::thread& th : pool) th.join();
  uint64_t x = 0;
  for (uint64_t p : partial) x ^= p;
  return x;
}

void Query(int repeats, int scale) {
  const Shape s{3, 3000 / scale, 4096};
  const Eigen::VectorXf q = Random(1, s.d, 99).row(0).transpose();
  const int threads = DistanceThreads();
  double float32_ms = 0, float32_stream = 0;
  for (StoragePrecision p :
       {StoragePrecision::kFloat32, StoragePrecision::kFloat16, StoragePrecision::kInt8}) {
    PlaceRecognizer r = MakeRecognizer(s, 10, p);
    const double ours =
        TimeMs(repeats, [&] { g_sink = static_cast<float>(r.Recognize(q, false).belief.match); });
    double stream = 0;
    r.ReadSets([&](const ReferenceSets& map) {
      stream = TimeMs(repeats, [&] { g_sink = static_cast<float>(StreamOnce(map, threads)); });
    });
    const double mb = static_cast<double>(s.m) * s.n * s.d * BytesPerElement(p) / 1e6;
    if (p == StoragePrecision::kFloat32) {
      float32_ms = ours;
      float32_stream = stream;
    }
    std::printf(
        "query   M=%d N=%d D=%d %-7s (%.0f MB), %d threads, %s kernel: end to end %.2f ms; "
        "streaming these bytes once %.2f ms (%.1f GB/s): %.2fx the memory limit",
        s.m, s.n, s.d, ToString(p).c_str(), mb, threads, DistanceKernel().c_str(), ours, stream,
        mb / stream, ours / stream);
    if (p == StoragePrecision::kFloat32) {
      std::printf("\n");
    } else {
      std::printf("; %.2fx float32's time (float32 memory limit: %.2fx)\n", ours / float32_ms,
                  ours / float32_stream);
    }
    if (p != StoragePrecision::kFloat32) continue;
    r.ReadSets([&](const ReferenceSets& map) {
      const RowMatrixXf q_row = q.transpose();
      const double ours_distances = TimeMs(repeats, [&] {
        g_sink = ComputeDistances(DistanceMetric::kEuclidean, q_row, map)[0](0, 0);
      });
      std::vector<std::unique_ptr<faiss::IndexFlatL2>> faiss_sets;
      for (const StoredReferenceSet& set : map.sets()) {
        faiss_sets.push_back(std::make_unique<faiss::IndexFlatL2>(s.d));
        faiss_sets.back()->add(set.size(), Float32Rows(set));
      }
      std::vector<float> dist(static_cast<size_t>(s.n));
      std::vector<faiss::Index::idx_t> label(static_cast<size_t>(s.n));
      const double faiss_ms = TimeMs(repeats, [&] {
        for (auto& index : faiss_sets) index->search(1, q.data(), s.n, dist.data(), label.data());
      });
      std::printf(
          "query   distances alone %.2f ms vs FAISS IndexFlatL2 (all N, k=N) %.2f ms: %.2fx "
          "FAISS's time\n",
          ours_distances, faiss_ms, ours_distances / faiss_ms);
    });
  }
}

void Batch(int repeats, int scale) {
  const Shape s{3, 3000 / scale, 4096};
  const int nq = 500 / scale;
  const ReferenceSets map = MakeSets(s, 20);
  const RowMatrixXf queries = Random(nq, s.d, 77);
  EvaluationInput in;
  in.num_queries = nq;
  in.num_places = s.n;
  in.set_names = map.SetNames();
  in.distances = [&](int b, int e, std::vector<RowMatrixXf>* block) {
    *block = ComputeDistances(DistanceMetric::kEuclidean, queries.middleRows(b, e - b), map);
  };
  const GroundTruth truth = GroundTruth::FromFrameTolerance(nq, s.n, 2);
  const std::vector<Method> bsf = {ParseMethod("bsf", in.set_names)};
  const int threads = DistanceThreads();
  openblas_set_num_threads(threads);
  RowMatrixXf product(nq, s.n);
  // The evaluation, the distances alone and the GEMM timed in turn: the ratios are medians
  // over the rounds, so that a slow spell of a shared machine falls on all three.
  const std::vector<std::vector<double>> ms = InterleavedTimesMs(
      repeats,
      {[&] { EvaluateMethods(in, bsf, {}, truth); },
       [&] { g_sink = ComputeDistances(DistanceMetric::kEuclidean, queries, map)[0](0, 0); },
       [&] {
         for (const StoredReferenceSet& set : map.sets()) {
           cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, nq, s.n, s.d, 1.0f, queries.data(),
                       s.d, Float32Rows(set), s.d, 0.0f, product.data(), s.n);
         }
         g_sink = product(0, 0);
       }});
  const double ours = Median(ms[0]), distances = Median(ms[1]), gemm = Median(ms[2]);
  std::printf(
      "batch   Q=%d M=%d N=%d D=%d, timed in turn: evaluation %.0f ms (%.2f ms/query), distances "
      "alone %.0f ms (%s kernel); OpenBLAS sgemm (%s) of the same shape on %d threads %.0f ms: "
      "the distances at %.0f%% of the GEMM throughput, the evaluation at %.0f%%\n",
      nq, s.m, s.n, s.d, ours, ours / nq, distances, DistanceKernel().c_str(),
      openblas_get_corename(), threads, gemm, 100.0 * MedianRatio(ms[2], ms[1]),
      100.0 * MedianRatio(ms[2], ms[0]));
}

// Each shape exact, then (D above the first stage's d') with the pca first stage at its
// defaults: its index's build time and bytes, and the time per query through it.
void Scaling(int repeats, int scale, StoragePrecision storage, const FirstStageOptions& pca) {
  std::printf("scaling (%s storage; pca: d'=%d, %d re-ranked per set, basis from %d rows)\n",
              ToString(storage).c_str(), pca.approximate.dimensions, pca.approximate.rerank,
              pca.approximate.sample_rows);
  std::printf(
      "scaling        N     M      D   exact ms/query   descriptor MB   resident MB   ratio"
      "   pca ms/query   speed-up   index s   index MB\n");
  const double limit = 0.75 * AvailableBytes();
  // Every block of 1 MB or more mapped on its own and returned when freed: otherwise glibc
  // raises its threshold after the first large free and the next shape reuses the heap the
  // last one left, so that its resident growth reads as zero.
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  for (int n : {1000, 10000, 100000}) {
    for (int m : {1, 3, 10}) {
      for (int d : {256, 1024, 4096}) {
        const Shape s{m, n / (scale == 1 ? 1 : 100), d};
        const double bytes = static_cast<double>(BytesPerElement(storage)) * s.m * s.n * s.d;
        // A reduced-precision set is made as float32 first and converted.
        const double peak = bytes + (storage == StoragePrecision::kFloat32 ? 0.0 : 4.0 * s.n * s.d);
        if (peak > limit) {
          std::printf(
              "scaling  %7d  %4d  %5d   skipped (%.1f GB of descriptors; %.1f GB is 3/4 of the "
              "memory available)\n",
              s.n, m, d, bytes / 1e9, limit / 1e9);
          continue;
        }
        const size_t before = ResidentBytes();
        PlaceRecognizer r = MakeRecognizer(s, 30, storage);
        const Eigen::VectorXf q = Random(1, d, 5).row(0).transpose();
        const auto time_query = [&] {
          return TimeMs(std::max(1, repeats / 2),
                        [&] { g_sink = static_cast<float>(r.Recognize(q, false).belief.match); });
        };
        const double ms = time_query();
        const double resident = static_cast<double>(ResidentBytes() - before);
        std::printf("scaling  %7d  %4d  %5d  %15.2f  %14.1f  %12.1f   %5.2f", s.n, m, d, ms,
                    bytes / 1e6, resident / 1e6, resident / bytes);
        if (d > pca.approximate.dimensions) {
          // The first stage over the same sets: its index built here, its distances decided
          // as the recogniser decides them.
          tools::StageQuery through(r);
          r.ReadSets([&](const ReferenceSets& map) {
            through.BuildJoint(map);
            DistanceStage stage;
            stage.SetOptions(pca);
            const auto t0 = std::chrono::steady_clock::now();
            stage.Prepare(map);
            const double index_s =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const RowMatrixXf q_row = q.transpose();
            const double pca_ms = TimeMs(std::max(1, repeats / 2), [&] {
              g_sink = static_cast<float>(through.Decide(stage, map, q_row).belief.match);
            });
            std::printf("  %13.2f  %8.1fx  %8.2f  %9.1f", pca_ms, ms / pca_ms, index_s,
                        stage.index()->MemoryBytes() / 1e6);
          });
        }
        std::printf("\n");
      }
    }
  }
}

int Run(int argc, char** argv) {
  std::string sections = "fusion,query,batch,evaluate,large,describe,scaling,joint,offmap,mapped";
  std::string mapped_dir = "/tmp/bsf_benchmark_mapped";
  std::string evaluate_dir = "/tmp/bsf_benchmark_evaluate";
  std::string images = std::string(BSF_SOURCE_DIR) + "/data/nordland_subset100/256x144/summer";
  int repeats = 7, scale = 1;
  StoragePrecision storage = StoragePrecision::kFloat32;
  FirstStageOptions first_stage;  // of the large and scaling sections
  first_stage.kind = ToString(FirstStageKind::kPca);
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "-h" || f == "--help") {
      std::cout << kUsage;
      return 0;
    }
    if (f == "--quick") {
      scale = 10;
      continue;
    }
    if (i + 1 >= argc) throw std::invalid_argument(f + " needs a value");
    const std::string v = argv[++i];
    if (f == "--sections")
      sections = v;
    else if (f == "--repeats")
      repeats = tools::ParseInteger(f, v);
    else if (f == "--storage")
      storage = tools::ForFlag(f, [&] { return ParseStoragePrecision(v); });
    else if (f == "--evaluate-dir")
      evaluate_dir = v;
    else if (f == "--images")
      images = v;
    else if (f == "--mapped-dir")
      mapped_dir = v;
    else if (f != "--first-stage" && FirstStageOptionsTable().SetFromFlag(f, v, &first_stage))
      continue;  // --first-stage-dimensions, --rerank-candidates, --first-stage-sample-rows
    else
      throw std::invalid_argument("unknown option '" + f + "' (see --help)");
  }
  if (repeats < 1) throw std::invalid_argument("--repeats must be >= 1");
  std::printf("%s\n", tools::MachineLine().c_str());
  std::stringstream ss(sections);
  for (std::string s; std::getline(ss, s, ',');) {
    if (s == "fusion")
      tools::BenchmarkFusion(repeats, scale);
    else if (s == "query")
      Query(repeats, scale);
    else if (s == "batch")
      Batch(repeats, scale);
    else if (s == "large")
      tools::BenchmarkLarge(std::max(repeats, 3), scale == 1 ? 1 : 100, first_stage);
    else if (s == "evaluate")
      tools::BenchmarkEvaluate(repeats, scale, evaluate_dir + (scale == 1 ? "" : "_quick"));
    else if (s == "describe")
      tools::BenchmarkDescribe(repeats, scale, images,
                               std::string(BSF_SOURCE_DIR) + "/test/data/models");
    else if (s == "scaling")
      Scaling(repeats, scale, storage, first_stage);
    else if (s == "joint")
      tools::BenchmarkJoint(repeats, scale);
    else if (s == "offmap")
      tools::BenchmarkOffMap(repeats, scale);
    else if (s == "mapped")
      tools::BenchmarkMapped(repeats, scale == 1 ? 1 : 100, first_stage,
                             mapped_dir + (scale == 1 ? "" : "_quick"));
    else
      throw std::invalid_argument(
          "unknown section '" + s +
          "' (fusion, query, batch, evaluate, large, describe, scaling, joint, offmap, mapped)");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // The baselines' OpenBLAS must fit the CPU: re-run with OPENBLAS_CORETYPE if it does not.
  bsf_vpr::tools::EnsureFittingOpenBlas(argv);
  return bsf_vpr::tools::RunTool("bsf_benchmark", Run, argc, argv);
}
