#include "bsf_vpr/core/reference_set_io.h"

#include <yaml-cpp/yaml.h>

#include <set>
#include <stdexcept>

#include "bsf_vpr/core/distances.h"
#include "bsf_vpr/core/file_util.h"
#include "bsf_vpr/core/npy.h"

namespace bsf_vpr {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

ReferenceSet ParseSidecar(const YAML::Node& root, const std::string& yaml_path) {
  if (!root.IsMap()) throw std::runtime_error("is not a YAML mapping");
  static const std::set<std::string> kKnown = {"name",      "condition", "descriptor_type",
                                               "dimension", "distance",  "descriptors",
                                               "place_ids", "poses"};
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!kKnown.count(key)) throw std::runtime_error("unknown key '" + key + "'");
  }
  if (!root["name"]) throw std::runtime_error("missing required key 'name'");
  if (!root["descriptors"]) throw std::runtime_error("missing required key 'descriptors'");
  const std::string npy = ResolvePath(DirName(yaml_path), root["descriptors"].as<std::string>());
  ReferenceSet set = MakeReferenceSet(root["name"].as<std::string>(), ReadNpyMatrix(npy));
  if (root["condition"]) set.condition = root["condition"].as<std::string>();
  if (root["descriptor_type"]) set.descriptor_type = root["descriptor_type"].as<std::string>();
  if (root["distance"]) {
    set.distance = root["distance"].as<std::string>();
    ParseDistanceMetric(set.distance);  // refuses unknown names
  }
  if (root["dimension"] && root["dimension"].as<int>() != set.dimension()) {
    throw std::runtime_error("declares dimension " + root["dimension"].as<std::string>() +
                             " but '" + npy + "' has " + std::to_string(set.dimension()) +
                             " columns");
  }
  if (root["place_ids"]) {
    set.place_ids = root["place_ids"].as<std::vector<int>>();
    if (set.place_ids.size() != static_cast<size_t>(set.size())) {
      throw std::runtime_error("lists " + std::to_string(set.place_ids.size()) + " place_ids for " +
                               std::to_string(set.size()) + " descriptors");
    }
  }
  if (root["poses"]) {
    for (const auto& p : root["poses"]) {
      const std::vector<double> v = p.as<std::vector<double>>();
      if (v.size() != 4) throw std::runtime_error("a pose must be [x, y, z, yaw]");
      set.poses.push_back({v[0], v[1], v[2], v[3]});
    }
  }
  set.Validate();
  return set;
}

}  // namespace

ReferenceSet LoadReferenceSetYaml(const std::string& yaml_path) {
  try {
    return ParseSidecar(YAML::LoadFile(yaml_path), yaml_path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error("cannot read reference set file '" + yaml_path + "'");
  } catch (const std::exception& e) {
    throw std::runtime_error("reference set file '" + yaml_path + "': " + e.what());
  }
}

ReferenceSet LoadReferenceSetNpy(const std::string& npy_path, const std::string& name) {
  ReferenceSet set = MakeReferenceSet(name, ReadNpyMatrix(npy_path));
  try {
    set.Validate();
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + npy_path + "': " + e.what());
  }
  return set;
}

ReferenceSet LoadReferenceSetFile(const std::string& path, const std::string& name) {
  if (EndsWith(path, ".yaml") || EndsWith(path, ".yml")) {
    ReferenceSet set = LoadReferenceSetYaml(path);
    if (!name.empty()) set.name = name;
    return set;
  }
  if (EndsWith(path, ".npy")) return LoadReferenceSetNpy(path, name);
  throw std::runtime_error("'" + path + "' is neither a reference-set .yaml nor a descriptor .npy");
}

void SaveReferenceSet(const ReferenceSet& set, const std::string& yaml_path) {
  set.Validate();
  std::string stem = yaml_path;
  if (EndsWith(stem, ".yaml"))
    stem.resize(stem.size() - 5);
  else if (EndsWith(stem, ".yml"))
    stem.resize(stem.size() - 4);
  if (set.descriptors.rows() != set.size()) {
    throw std::invalid_argument("reference set '" + set.name + "' is held at " +
                                ToString(set.store.precision) +
                                " precision only; save it from its float32 source");
  }
  const std::string npy_path = stem + ".npy";
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << set.name;
  if (!set.condition.empty()) out << YAML::Key << "condition" << YAML::Value << set.condition;
  if (!set.descriptor_type.empty()) {
    out << YAML::Key << "descriptor_type" << YAML::Value << set.descriptor_type;
  }
  out << YAML::Key << "dimension" << YAML::Value << set.dimension();
  if (!set.distance.empty()) out << YAML::Key << "distance" << YAML::Value << set.distance;
  out << YAML::Key << "descriptors" << YAML::Value << BaseName(npy_path);
  out << YAML::Key << "place_ids" << YAML::Value << YAML::Flow << set.place_ids;
  if (!set.poses.empty()) {
    out << YAML::Key << "poses" << YAML::Value << YAML::BeginSeq;
    for (const PlacePose& p : set.poses) {
      out << YAML::Flow << std::vector<double>{p.x_m, p.y_m, p.z_m, p.yaw_rad};
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;
  WriteNpyMatrix(npy_path, set.descriptors);
  WriteFileAtomically(yaml_path, std::string(out.c_str()) + "\n");
}

}  // namespace bsf_vpr
