// The CSV files of dataset layouts (RobotCar's gps/ins.csv, a Nordland GPS log, generic
// pose files): a header naming the columns, then one record per line. Columns are found by
// name, so that extra columns (RobotCar's ins_status, velocities) are passed over; every
// message names the file and the line.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace bsf_vpr {
namespace tools {

class CsvTable {
 public:
  // Reads `path`: the first line is the header (names are trimmed and compared in lower
  // case), blank lines are skipped, every other line must have as many fields as the
  // header. Throws std::runtime_error naming the file (and line) otherwise.
  static CsvTable Read(const std::string& path);

  // The index of the first column named one of `names` (lower case), or -1.
  int Find(const std::vector<std::string>& names) const;
  // The same, but throws std::runtime_error naming the file and the column wanted.
  int Require(const std::vector<std::string>& names) const;

  size_t rows() const { return rows_.size(); }
  // Field `column` of row `row` as a finite number / as a whole number; throws
  // std::runtime_error "'<file>' line <n>: column '<name>' ..." otherwise.
  double Number(size_t row, int column) const;
  int64_t Integer(size_t row, int column) const;
  // "'<file>' line <n>" of a row, for messages.
  std::string Where(size_t row) const;
  const std::string& path() const { return path_; }
  const std::vector<std::string>& header() const { return header_; }

 private:
  std::string path_;
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<int> lines_;  // 1-based line number of each row
};

}  // namespace tools
}  // namespace bsf_vpr
