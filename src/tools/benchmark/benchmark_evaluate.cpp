#include "src/tools/benchmark/benchmark_evaluate.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "bsf_vpr/io/file_util.h"
#include "src/tools/common/cli_util.h"

namespace bsf_vpr {
namespace tools {
namespace {

// The folder of this executable: bsf_evaluate, bsf_make_synthetic and numpy_bsf are
// installed (and in the devel space, linked) beside it.
std::string OwnFolder() {
  std::vector<char> buf(4096);
  const ssize_t n = readlink("/proc/self/exe", buf.data(), buf.size() - 1);
  if (n <= 0) throw std::runtime_error("cannot find this executable's folder (/proc/self/exe)");
  const std::string exe(buf.data(), static_cast<size_t>(n));
  return exe.substr(0, exe.rfind('/'));
}

struct Run {
  double wall_s = 0, cpu_s = 0;
  std::string output;  // stdout and stderr
};

// Runs `command` through the shell; its wall time and the CPU time of it and its children.
Run Timed(const std::string& command) {
  const double cpu_before = CpuSeconds(RUSAGE_CHILDREN);
  const auto t0 = std::chrono::steady_clock::now();
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) throw std::runtime_error("cannot run: " + command);
  Run r;
  char buf[4096];
  for (size_t got; (got = fread(buf, 1, sizeof buf, pipe)) > 0;) r.output.append(buf, got);
  const int status = pclose(pipe);
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_s = CpuSeconds(RUSAGE_CHILDREN) - cpu_before;
  if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("failed: " + command + "\n" + r.output);
  }
  return r;
}

// The file's text, or "" if it cannot be read (the data folder's stamp before the first run).
std::string TextIfPresent(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The numbers of a CSV file's lines after the header (one vector per line).
std::vector<std::vector<double>> CsvNumbers(const std::string& path) {
  std::stringstream in(ReadFile(path));  // written by the run just made: missing is an error
  std::vector<std::vector<double>> rows;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream fields(line);
    std::vector<double> row;
    for (std::string f; std::getline(fields, f, ',');) {
      char* end = nullptr;
      const double v = std::strtod(f.c_str(), &end);
      row.push_back(end != f.c_str() ? v : 0.0);  // the method's name counts as 0
    }
    rows.push_back(row);
  }
  return rows;
}

// Whether two evaluations agree: the summary's metrics to 0.001 (the table's precision), and
// how many queries' matches differ (float32 sums in another order may break a near tie).
bool SameResults(const std::string& a_dir, const std::string& b_dir, int* differing_matches) {
  const auto a = CsvNumbers(a_dir + "/summary.csv"), b = CsvNumbers(b_dir + "/summary.csv");
  // The peer's columns are the first of ours (ours add the off-map counts).
  bool same = a.size() == 1 && b.size() == 1 && a[0].size() >= b[0].size() && !b[0].empty();
  for (size_t k = 0; same && k < b[0].size(); ++k) same = std::abs(a[0][k] - b[0][k]) <= 1e-3;
  const auto ma = CsvNumbers(a_dir + "/matches/bsf.csv"),
             mb = CsvNumbers(b_dir + "/matches/bsf.csv");
  *differing_matches = 0;
  for (size_t q = 0; q < std::min(ma.size(), mb.size()); ++q) {
    *differing_matches += ma[q].at(1) != mb[q].at(1) ? 1 : 0;
  }
  return same && ma.size() == mb.size();
}

// The line of bsf_evaluate --timings, without its prefix.
std::string PhaseLine(const std::string& output) {
  const std::string key = "bsf_evaluate: timings: ";
  const size_t at = output.find(key);
  if (at == std::string::npos) return "(no timings)";
  const size_t end = output.find('\n', at);
  return output.substr(at + key.size(), end - at - key.size());
}

}  // namespace

void BenchmarkEvaluate(int repeats, int scale, const std::string& data_dir) {
  const std::string bin = OwnFolder();
  const int n = 3000 / scale, d = 4096 / scale;
  const std::string stamp = data_dir + "/shape.txt";
  const std::string shape = std::to_string(n) + " x " + std::to_string(d) + "\n";
  if (TextIfPresent(stamp) != shape) {
    Timed(bin + "/bsf_make_synthetic --out " + data_dir + " --places " + std::to_string(n) +
          " --dimension " + std::to_string(d));
    WriteFileAtomically(stamp, shape);
  }
  std::string inputs;
  for (int u = 0; u < 3; ++u) {
    inputs +=
        " --reference c" + std::to_string(u) + "=" + data_dir + "/c" + std::to_string(u) + ".npy";
  }
  inputs += " --query " + data_dir + "/queries.npy --tolerance 2";
  // Two methods, each run by bsf_evaluate and by numpy_bsf: the mixture (bsf_evaluate's
  // defaults but --fusion mixture --off-map false) and the paper's method (fusion product,
  // the two-sided likelihood, relative selection, gamma 0.04, no off-map hypothesis).
  // The script is run by its interpreter: the devel space's relay and the source file alike.
  // Two NumPy peers each: blocks of 256 queries a matrix product, and every distance first
  // (one product per set), then the fusion of all queries; and NumPy's distances alone.
  struct Variant {
    std::string label, method, out;
    std::vector<double> ours_s, ours_cores, blocked_s, blocked_cores, first_s, first_cores;
    std::string phases;
  };
  std::vector<Variant> variants = {
      {"method bsf (fusion mixture, as the NumPy peers)",
       " --fusion mixture",
       "",
       {},
       {},
       {},
       {},
       {},
       {},
       ""},
      {"the paper's method (bsf --fusion product --likelihood two_sided, selection relative, "
       "gamma 0.04)",
       " --fusion product --likelihood two_sided",
       "_paper",
       {},
       {},
       {},
       {},
       {},
       {},
       ""}};
  const std::string numpy = "PATH=/usr/bin:$PATH /usr/bin/python3 " + bin + "/numpy_bsf" + inputs;
  std::vector<double> gemm_s, gemm_cores;
  for (int r = 0; r < repeats; ++r) {
    for (Variant& v : variants) {
      const Run a =
          Timed(bin + "/bsf_evaluate" + inputs + " --methods bsf" + v.method +
                " --off-map false --no-progress --timings --out " + data_dir + "/out_bsf" + v.out);
      v.ours_s.push_back(a.wall_s);
      v.ours_cores.push_back(a.cpu_s / a.wall_s);
      v.phases = PhaseLine(a.output);
      const Run b = Timed(numpy + v.method + " --out " + data_dir + "/out_numpy" + v.out);
      v.blocked_s.push_back(b.wall_s);
      v.blocked_cores.push_back(b.cpu_s / b.wall_s);
      const Run c =
          Timed(numpy + v.method + " --block 0 --out " + data_dir + "/out_numpy_all" + v.out);
      v.first_s.push_back(c.wall_s);
      v.first_cores.push_back(c.cpu_s / c.wall_s);
    }
    const Run g = Timed(numpy + " --block 0 --distances-only");
    gemm_s.push_back(g.wall_s);
    gemm_cores.push_back(g.cpu_s / g.wall_s);
  }
  for (const Variant& v : variants) {
    int differing = 0, differing_first = 0;
    const bool same =
        SameResults(data_dir + "/out_bsf" + v.out, data_dir + "/out_numpy" + v.out, &differing);
    const bool same_first = SameResults(data_dir + "/out_bsf" + v.out,
                                        data_dir + "/out_numpy_all" + v.out, &differing_first);
    std::printf(
        "evaluate  Q=%d M=3 N=%d D=%d, %s, .npy in, summary and matches out: bsf_evaluate %.2f s "
        "(%.2f cores busy) vs NumPy + OpenBLAS (scripts/numpy_bsf, 256 queries a GEMM) %.2f s "
        "(%.2f cores): NumPy's time / bsf_evaluate's %.2fx; %d of %d matches differ%s\n",
        n, n, d, v.label.c_str(), Median(v.ours_s), Median(v.ours_cores), Median(v.blocked_s),
        Median(v.blocked_cores), Median(v.blocked_s) / Median(v.ours_s), differing, n,
        same ? "" : "; RESULTS DIFFER");
    std::printf(
        "evaluate  vs NumPy with every distance first (numpy_bsf --block 0: one GEMM per set, "
        "then all queries fused) %.2f s (%.2f cores): NumPy's time / bsf_evaluate's %.2fx; %d "
        "of %d matches differ%s\n",
        Median(v.first_s), Median(v.first_cores), Median(v.first_s) / Median(v.ours_s),
        differing_first, n, same_first ? "" : "; RESULTS DIFFER");
    std::printf("evaluate  bsf_evaluate's phases: %s (last run)\n", v.phases.c_str());
  }
  std::printf(
      "evaluate  NumPy's distances alone (numpy_bsf --block 0 --distances-only: loading, one "
      "GEMM per set with the norms) %.2f s (%.2f cores)\n",
      Median(gemm_s), Median(gemm_cores));
}

}  // namespace tools
}  // namespace bsf_vpr
