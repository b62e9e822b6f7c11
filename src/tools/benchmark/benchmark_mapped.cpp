#include "src/tools/benchmark/benchmark_mapped.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "bsf_vpr/io/reference_set_io.h"
#include "bsf_vpr/map/local_map.h"
#include "src/tools/benchmark/benchmark_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

using Clock = std::chrono::steady_clock;

// Drops the file's pages from the page cache (clean pages need no privilege): the next
// read of it comes from the disk, as after a reboot.
void EvictFromPageCache(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  close(fd);
}

// Writes set `name` (n x d int8, random) as bsf_store_set does, unless it is there.
void WriteSet(const std::string& dir, const std::string& name, int n, int d, uint64_t seed) {
  const std::string yaml = dir + "/" + name + ".yaml";
  if (std::filesystem::exists(yaml)) {
    try {
      if (LoadReferenceSetFile(yaml, "").size() == n) return;
    } catch (const std::exception&) {
    }
  }
  ReferenceSets map;
  map.SetStoragePrecision(StoragePrecision::kInt8);
  ReferenceSet set = MakeReferenceSet(name, Uniform(n, d, seed));
  map.Add(std::move(set));
  SaveStoredReferenceSet(map.set(0), yaml);
}

QueryDescriptor Descriptor(const RowMatrixXf& queries, int q) {
  QueryDescriptor out;
  out.values = queries.row(q).data();
  out.size = queries.cols();
  return out;
}

}  // namespace

void BenchmarkMapped(int repeats, int scale, const FirstStageOptions& first_stage,
                     const std::string& dir) {
  const int m = 10, n = 100000 / scale, d = 4096;
  // Making a set holds it at float32 once (1.6 GB at full size).
  if (5.0 * n * d > 0.75 * AvailableBytes()) {
    std::printf("mapped  skipped: making a set of %d x %d needs %.1f GB\n", n, d,
                5.0 * n * d / 1e9);
    return;
  }
  std::filesystem::create_directories(dir);
  for (int u = 0; u <= m; ++u) WriteSet(dir, "s" + std::to_string(u), n, d, 300 + u);
  const std::string one = dir + "/s0.yaml";
  std::string npy;  // s0's rows: s0.int8.<content hash>.npy
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().filename().string().rfind("s0.int8.", 0) == 0) npy = e.path().string();
  }

  // Opening one set: mapped (its norms read) against read and encoded, each from the disk
  // (pages evicted first) and from the page cache.
  ReadSetOptions mapped;
  mapped.memory_map = StoragePrecision::kInt8;
  const auto open_set = [&](const ReadSetOptions& options) {
    ReferenceSets map;
    map.SetStoragePrecision(StoragePrecision::kInt8);
    map.Add(LoadReferenceSetFile(one, "", options));
  };
  std::vector<double> cold_mapped, cold_read;
  for (int r = 0; r < std::max(3, repeats / 2); ++r) {
    EvictFromPageCache(npy);
    auto t0 = Clock::now();
    open_set(mapped);
    cold_mapped.push_back(MsSince(t0));
    EvictFromPageCache(npy);
    t0 = Clock::now();
    open_set(ReadSetOptions());
    cold_read.push_back(MsSince(t0));
  }
  const std::vector<std::vector<double>> warm =
      InterleavedTimesMs(repeats, {[&] { open_set(mapped); }, [&] { open_set({}); }});
  std::printf(
      "mapped  open one set of %d x %d int8 (%.0f MB): memory-mapped %.0f ms from the disk, "
      "%.0f ms from the page cache; read into memory %.0f ms from the disk, %.0f ms from the "
      "page cache (%.1fx, %.1fx)\n",
      n, d, 1e-6 * n * d, Median(cold_mapped), Median(warm[0]), Median(cold_read), Median(warm[1]),
      Median(cold_read) / Median(cold_mapped), MedianRatio(warm[1], warm[0]));

  // The whole map through LocalMap (the fusion node's), mapped, with the pca first stage.
  const DataDirectory data(dir, /*create=*/false);
  LocalMapOptions options;
  options.storage = StoragePrecision::kInt8;
  options.memory_map = true;
  options.first_stage = first_stage;
  if (scale != 1) {  // --quick: a smaller sample for the basis (a smoke test's figures)
    options.first_stage.approximate.sample_rows =
        std::min(options.first_stage.approximate.sample_rows, 512);
  }
  const double rss0 = ResidentBytes() / 1e6, anon0 = AnonymousResidentBytes() / 1e6;
  LocalMap map(options, &data);
  auto t0 = Clock::now();
  std::vector<ConfiguredSet> sets;
  for (int u = 0; u < m; ++u) sets.push_back({dir + "/s" + std::to_string(u) + ".yaml", "", ""});
  map.LoadConfigured(sets);
  const double load_s = MsSince(t0) / 1000;
  map.WaitForIndex();
  const double index_s = MsSince(t0) / 1000 - load_s;
  const double rss_map = ResidentBytes() / 1e6 - rss0;
  const double anon_map = AnonymousResidentBytes() / 1e6 - anon0;
  const RowMatrixXf queries = Uniform(std::max(repeats, 20) + 1, d, 17);
  int q = 0;
  const double query_ms = TimeMs(
      repeats, [&] { map.Ask(Descriptor(queries, q++ % static_cast<int>(queries.rows()))); });
  const double rss_queried = ResidentBytes() / 1e6 - rss0;
  std::printf(
      "mapped  M=%d N=%d D=%d int8 memory-mapped, pca (d'=%d, %d re-ranked per set): sets "
      "opened in %.1f s, index built in the background in %.1f s (one thread); a query %.1f "
      "ms (%.1f queries/s); resident %.0f MB after the build (the process's own %.0f MB, the "
      "rest mapped pages of the page cache), %.0f MB after the queries (the rows as stored: "
      "%.0f MB)\n",
      m, n, d, first_stage.approximate.dimensions, first_stage.approximate.rerank, load_s, index_s,
      query_ms, 1000 / query_ms, rss_map, anon_map, rss_queried, 1e-6 * m * n * d);

  // A load while beliefs stream: queries back to back on one thread (as the node's
  // recognition thread takes descriptors), the 11th set loaded on another, its codes built
  // in the background; the delay of every query meanwhile.
  std::atomic<bool> done{false};
  std::vector<double> during;
  std::thread stream([&] {
    int k = 0;
    while (!done.load()) {
      const auto start = Clock::now();
      map.Ask(Descriptor(queries, k++ % static_cast<int>(queries.rows())));
      during.push_back(MsSince(start));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  t0 = Clock::now();
  map.Load({"s" + std::to_string(m) + ".yaml", "", "", ""}, nullptr);
  const double add_load_ms = MsSince(t0);
  map.WaitForIndex();
  const double add_index_s = MsSince(t0) / 1000;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  done = true;
  stream.join();
  std::vector<double> sorted = during;
  std::sort(sorted.begin(), sorted.end());
  std::printf(
      "mapped  a set of %d x %d loaded while queries stream: load answered in %.0f ms, its "
      "codes added in the background in %.1f s; %zu queries meanwhile: median %.1f ms, p99 "
      "%.1f ms, max %.1f ms (the beliefs' delay; a query alone: %.1f ms)\n",
      n, d, add_load_ms, add_index_s, sorted.size(), Median(during),
      sorted[std::min(sorted.size() - 1, sorted.size() * 99 / 100)], sorted.back(), query_ms);
}

}  // namespace tools
}  // namespace bsf_vpr
