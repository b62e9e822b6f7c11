// The names of the sets that a load, an unload or a stopped recording's load has taken until
// it ends: no other load or unload, no new recording and no method may take such a name
// meanwhile. Each taker releases its own hold only.
// Not thread-safe: the fusion node holds it under its mutex.
#pragma once

#include <iterator>
#include <map>
#include <stdexcept>
#include <string>

namespace bsf_vpr {

class BusySets {
 public:
  // Takes `name` for `what` ("loaded", "unloaded"). Throws std::invalid_argument naming what
  // holds it when it is taken already.
  void Take(const std::string& name, const std::string& what) {
    Check(name);
    busy_.emplace(name, what);
  }
  // Holds `name` for `what` whether or not another holds it too (a stopped recording's set,
  // saved already: it is loaded whatever else is under way).
  void Hold(const std::string& name, const std::string& what) { busy_.emplace(name, what); }
  // Ends one hold of `name` for `what` (the others stay).
  void Release(const std::string& name, const std::string& what) {
    const auto [first, last] = busy_.equal_range(name);
    for (auto it = first; it != last; ++it) {
      if (it->second == what) {
        busy_.erase(it);
        return;
      }
    }
  }
  bool empty() const { return busy_.empty(); }
  // Throws std::invalid_argument when `name` is held ("... is being loaded").
  void Check(const std::string& name) const {
    const auto it = busy_.find(name);
    if (it != busy_.end()) {
      throw std::invalid_argument("a reference set named '" + name + "' is being " + it->second);
    }
  }

 private:
  std::multimap<std::string, std::string> busy_;  // name -> what holds it
};

}  // namespace bsf_vpr
