#include "src/tools/import/import_csv.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace bsf_vpr {
namespace tools {
namespace {

std::string Trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    out.push_back(Trim(line.substr(start, comma - start)));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

}  // namespace

CsvTable CsvTable::Read(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  CsvTable t;
  t.path_ = path;
  std::string line;
  int line_no = 0;
  while (t.header_.empty() && std::getline(in, line)) {
    ++line_no;
    if (Trim(line).empty()) continue;
    t.header_ = Split(line);
    for (std::string& h : t.header_) {
      std::transform(h.begin(), h.end(), h.begin(),
                     [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    }
  }
  if (t.header_.empty()) throw std::runtime_error("'" + path + "' is empty (no header line)");
  while (std::getline(in, line)) {
    ++line_no;
    if (Trim(line).empty()) continue;
    std::vector<std::string> fields = Split(line);
    if (fields.size() != t.header_.size()) {
      throw std::runtime_error("'" + path + "' line " + std::to_string(line_no) + ": " +
                               std::to_string(fields.size()) + " fields, the header has " +
                               std::to_string(t.header_.size()));
    }
    t.rows_.push_back(std::move(fields));
    t.lines_.push_back(line_no);
  }
  return t;
}

int CsvTable::Find(const std::vector<std::string>& names) const {
  for (const std::string& n : names) {
    const auto it = std::find(header_.begin(), header_.end(), n);
    if (it != header_.end()) return static_cast<int>(it - header_.begin());
  }
  return -1;
}

int CsvTable::Require(const std::vector<std::string>& names) const {
  const int c = Find(names);
  if (c >= 0) return c;
  std::string wanted;
  for (const std::string& n : names) wanted += (wanted.empty() ? "'" : " or '") + n + "'";
  throw std::runtime_error("'" + path_ + "' line 1: no column " + wanted);
}

std::string CsvTable::Where(size_t row) const {
  return "'" + path_ + "' line " + std::to_string(lines_.at(row));
}

double CsvTable::Number(size_t row, int column) const {
  const std::string& text = rows_.at(row).at(static_cast<size_t>(column));
  char* end = nullptr;
  const double v = text.empty() ? 0 : std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw std::runtime_error(Where(row) + ": column '" + header_[static_cast<size_t>(column)] +
                             "' expects a number, got '" + text + "'");
  }
  return v;
}

int64_t CsvTable::Integer(size_t row, int column) const {
  const std::string& text = rows_.at(row).at(static_cast<size_t>(column));
  int64_t v = 0;
  const std::from_chars_result r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) {
    throw std::runtime_error(Where(row) + ": column '" + header_[static_cast<size_t>(column)] +
                             "' expects a whole number, got '" + text + "'");
  }
  return v;
}

}  // namespace tools
}  // namespace bsf_vpr
