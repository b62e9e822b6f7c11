// Shared by the tool tests: running a command as a user would, and reading what the
// evaluator wrote.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace bsf_vpr {
namespace testing {

struct Result {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

inline Result RunCommand(const std::string& command) {
  Result r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline Result Evaluate(const std::string& args) {
  return RunCommand(std::string(BSF_EVALUATE_PATH) + " " + args);
}

// A tool's refusal of bad input: exit status 2 and one line of output containing `fragment`
// (what the tool was asked, `what`, is shown on failure).
inline void ExpectOneLineRefusal(const Result& r, const std::string& fragment,
                                 const std::string& what) {
  EXPECT_EQ(r.exit_code, 2) << what << "\n" << r.output;
  EXPECT_NE(r.output.find(fragment), std::string::npos) << what << "\n" << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << what << "\n" << r.output;
}

inline std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// summary.csv as method -> column -> value.
inline std::map<std::string, std::map<std::string, double>> Summary(const std::string& dir) {
  const std::vector<std::string> lines = Lines(dir + "/summary.csv");
  std::map<std::string, std::map<std::string, double>> out;
  const std::vector<std::string> cols = {
      "auc",     "r_at_100p", "r_at_1",          "r_at_5",
      "r_at_10", "n_queries", "off_map_queries", "off_map_accepted"};
  for (size_t i = 1; i < lines.size(); ++i) {
    std::stringstream ss(lines[i]);
    std::string method, v;
    std::getline(ss, method, ',');
    for (const std::string& c : cols) {
      std::getline(ss, v, ',');
      out[method][c] = std::stod(v);
    }
  }
  return out;
}

}  // namespace testing
}  // namespace bsf_vpr
