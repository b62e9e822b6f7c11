// Reading parameters of the bsf_vpr nodes.
#pragma once

#include <ros/node_handle.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace bsf_vpr {

// The value of ~key, or `fallback` when it is not set. Throws std::invalid_argument naming
// the parameter when it is set with the wrong type.
template <typename T>
T GetParam(const ros::NodeHandle& pnh, const std::string& key, const T& fallback) {
  if (!pnh.hasParam(key)) return fallback;
  T value;
  if (!pnh.getParam(key, value)) {
    throw std::invalid_argument("parameter '" + pnh.resolveName(key) + "' has the wrong type");
  }
  return value;
}

// Throws std::invalid_argument listing the keys under `pnh` that are not in `known` (a
// misspelt parameter would otherwise be silently ignored).
void RefuseUnknownParams(const ros::NodeHandle& pnh, const std::vector<std::string>& known);

}  // namespace bsf_vpr
