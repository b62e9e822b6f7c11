// Shared by the command-line tools: number parsing with messages naming the flag, CPU time,
// and the convention that any error ends the tool with one line on stderr and exit status 2.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace bsf_vpr {
namespace tools {

constexpr int kExitBadInput = 2;

// A finite number / a whole number; throws std::invalid_argument "<flag> expects ...".
double ParseNumber(const std::string& flag, const std::string& value);
int ParseInteger(const std::string& flag, const std::string& value);

// parse() with `flag` named in its error: "<flag>: <what>" (for parsers of names, e.g.
// ParseDistanceMetric, whose messages do not know the flag).
template <class Parse>
auto ForFlag(const std::string& flag, Parse parse) -> decltype(parse()) {
  try {
    return parse();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(flag + ": " + e.what());
  }
}

// User plus system CPU seconds so far of this process (RUSAGE_SELF) or of its waited-for
// children (RUSAGE_CHILDREN), as getrusage(2) gives them.
double CpuSeconds(int who);

// Creates `dir` and its missing parents / the folder that will hold `file` (nothing when the
// path has no folder part). Throws std::runtime_error naming the folder and the reason.
void CreateFolders(const std::string& dir);
void CreateParentFolders(const std::string& file);

// Reads the "--flag value" pairs of argv in order; a flag among `switches` stands alone (its
// value is ""). Next() returns false at the end or at -h/--help (then help() is true); it
// throws std::invalid_argument for a flag without value or a renamed one (RefuseRenamedFlag).
class FlagReader {
 public:
  FlagReader(int argc, char** argv, std::vector<std::string> switches = {})
      : argc_(argc), argv_(argv), switches_(std::move(switches)) {}
  bool Next(std::string* flag, std::string* value);
  bool help() const { return help_; }

 private:
  int argc_;
  char** argv_;
  std::vector<std::string> switches_;
  int i_ = 1;
  bool help_ = false;
};

// Throws std::invalid_argument naming the new spelling when `flag` is one that was renamed
// so that each option has one name everywhere (--gamma is now --gamma-fraction, as the ROS
// parameter gamma_fraction).
void RefuseRenamedFlag(const std::string& flag);

// Runs `run(argc, argv)`; an exception becomes "<tool>: error: <what>" and kExitBadInput.
int RunTool(const char* tool, int (*run)(int, char**), int argc, char** argv);

}  // namespace tools
}  // namespace bsf_vpr
