#include "bsf_vpr/evaluation/ground_truth_io.h"

#include <sstream>
#include <stdexcept>

#include "bsf_vpr/io/file_util.h"
#include "bsf_vpr/io/npy.h"

namespace bsf_vpr {
namespace {

// Parses a whole decimal integer; false if `text` is anything else.
bool ParseInt(const std::string& text, int* value) {
  size_t used = 0;
  try {
    *value = std::stoi(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == text.size();
}

}  // namespace

GroundTruth ReadGroundTruthCsv(const std::string& path, int num_queries, int num_places) {
  std::istringstream in(ReadFile(path));
  std::vector<std::vector<int>> correct(static_cast<size_t>(num_queries));
  std::vector<bool> seen(static_cast<size_t>(num_queries), false);
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& what) {
    throw std::runtime_error("ground truth '" + path + "' line " + std::to_string(line_no) + ": " +
                             what);
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || (line_no == 1 && line.rfind("query", 0) == 0)) continue;
    const size_t comma = line.find(',');
    if (comma == std::string::npos) fail("expected 'query,places', got '" + line + "'");
    int query = 0;
    if (!ParseInt(line.substr(0, comma), &query)) fail("query id is not an integer");
    if (query < 0 || query >= num_queries) {
      fail("query " + std::to_string(query) + " is outside 0.." + std::to_string(num_queries - 1));
    }
    if (seen[static_cast<size_t>(query)]) fail("query " + std::to_string(query) + " listed twice");
    seen[static_cast<size_t>(query)] = true;
    std::istringstream places(line.substr(comma + 1));
    std::string token;
    while (places >> token) {
      int place = 0;
      if (!ParseInt(token, &place)) fail("place '" + token + "' is not an integer");
      if (place < 0 || place >= num_places) {
        fail("place " + std::to_string(place) + " is outside 0.." + std::to_string(num_places - 1));
      }
      correct[static_cast<size_t>(query)].push_back(place);
    }
  }
  return GroundTruth(std::move(correct));
}

GroundTruth ReadGroundTruthNpy(const std::string& path, int num_queries, int num_places) {
  const std::string bytes = ReadFile(path);
  const NpyHeader h = ParseNpyHeader(bytes, path);
  if (h.rows != num_queries || h.cols != num_places) {
    const std::string shape = std::to_string(h.rows) + " x " + std::to_string(h.cols);
    std::string message = "ground truth '" + path + "' is " + shape + " but the evaluation has " +
                          std::to_string(num_queries) + " queries and " +
                          std::to_string(num_places) +
                          " places: expected a queries x places matrix";
    if (h.rows == num_places && h.cols == num_queries) {
      message +=
          " (this one looks transposed: the VPR tutorial's GThard is places x queries, "
          "save GThard.T)";
    }
    throw std::runtime_error(message);
  }
  const RowMatrixXb truth = DecodeNpyBoolMatrix(bytes, path);
  std::vector<std::vector<int>> correct(static_cast<size_t>(num_queries));
  for (int q = 0; q < num_queries; ++q) {
    for (int i = 0; i < num_places; ++i) {
      if (truth(q, i)) correct[static_cast<size_t>(q)].push_back(i);
    }
  }
  return GroundTruth(std::move(correct));
}

GroundTruth ReadGroundTruthFile(const std::string& path, int num_queries, int num_places) {
  const std::string npy = ".npy";
  if (path.size() >= npy.size() && path.compare(path.size() - npy.size(), npy.size(), npy) == 0) {
    return ReadGroundTruthNpy(path, num_queries, num_places);
  }
  return ReadGroundTruthCsv(path, num_queries, num_places);
}

void WriteGroundTruthCsv(const std::string& path, const GroundTruth& truth) {
  std::ostringstream out;
  out << "query,correct_places\n";
  for (int q = 0; q < truth.num_queries(); ++q) {
    if (!truth.HasTrueMatch(q)) continue;
    out << q << ',';
    const std::vector<int>& c = truth.CorrectPlaces(q);
    for (size_t k = 0; k < c.size(); ++k) out << (k ? " " : "") << c[k];
    out << '\n';
  }
  WriteFileAtomically(path, out.str());
}

}  // namespace bsf_vpr
