// The names of the sets that a load, an unload or a stopped recording's load has taken until
// it ends: no other of them, no new recording and no method may take such a name meanwhile.
// Not thread-safe: the fusion node holds it under its mutex.
#pragma once

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
    busy_[name] = what;
  }
  // Takes `name` whatever holds it (a recording's own set, which nothing else can hold).
  void Hold(const std::string& name, const std::string& what) { busy_[name] = what; }
  void Release(const std::string& name) { busy_.erase(name); }
  bool empty() const { return busy_.empty(); }
  // Throws std::invalid_argument when `name` is taken ("... is being loaded").
  void Check(const std::string& name) const {
    const auto it = busy_.find(name);
    if (it != busy_.end()) {
      throw std::invalid_argument("a reference set named '" + name + "' is being " + it->second);
    }
  }

 private:
  std::map<std::string, std::string> busy_;  // name -> what holds it
};

}  // namespace bsf_vpr
