#include "param_util.h"

#include <ros/param.h>

#include <algorithm>
#include <stdexcept>

namespace bsf_vpr {

void RefuseUnknownParams(const ros::NodeHandle& pnh, const std::vector<std::string>& known) {
  std::vector<std::string> all;
  ros::param::getParamNames(all);
  const std::string prefix = pnh.getNamespace() + "/";
  std::vector<std::string> unknown;
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string key =
        name.substr(prefix.size(), name.find('/', prefix.size()) - prefix.size());
    if (std::find(known.begin(), known.end(), key) == known.end() &&
        std::find(unknown.begin(), unknown.end(), key) == unknown.end()) {
      unknown.push_back(key);
    }
  }
  if (!unknown.empty()) {
    std::string list;
    for (const std::string& k : unknown) list += (list.empty() ? "" : ", ") + prefix + k;
    throw std::invalid_argument("unknown parameter(s): " + list);
  }
}

}  // namespace bsf_vpr
