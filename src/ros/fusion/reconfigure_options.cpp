#include "src/ros/fusion/reconfigure_options.h"

#include <stdexcept>

namespace bsf_vpr {

NamedOptionValues ValuesFromConfig(const dynamic_reconfigure::Config& config) {
  NamedOptionValues out;
  for (const auto& p : config.bools) out.emplace_back(p.name, static_cast<bool>(p.value));
  for (const auto& p : config.ints) out.emplace_back(p.name, static_cast<long long>(p.value));
  for (const auto& p : config.doubles) out.emplace_back(p.name, p.value);
  for (const auto& p : config.strs) out.emplace_back(p.name, p.value);
  return out;
}

dynamic_reconfigure::Config ConfigFromValues(const NamedOptionValues& values) {
  dynamic_reconfigure::Config config;
  for (const auto& [name, value] : values) {
    if (const bool* b = std::get_if<bool>(&value)) {
      dynamic_reconfigure::BoolParameter p;
      p.name = name;
      p.value = *b;
      config.bools.push_back(p);
    } else if (const long long* i = std::get_if<long long>(&value)) {
      dynamic_reconfigure::IntParameter p;
      p.name = name;
      p.value = static_cast<int>(*i);
      config.ints.push_back(p);
    } else if (const double* d = std::get_if<double>(&value)) {
      dynamic_reconfigure::DoubleParameter p;
      p.name = name;
      p.value = *d;
      config.doubles.push_back(p);
    } else if (const std::string* s = std::get_if<std::string>(&value)) {
      dynamic_reconfigure::StrParameter p;
      p.name = name;
      p.value = *s;
      config.strs.push_back(p);
    } else {
      throw std::invalid_argument("option " + name + " is a list: dynamic_reconfigure has none");
    }
  }
  return config;
}

}  // namespace bsf_vpr
