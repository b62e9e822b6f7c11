// dynamic_reconfigure's Config message as option values by name, and back: the fusion
// node applies a reconfiguration through RecognizerOptionsTable() (its live options), the
// same declaration its parameters and cfg/Fusion.cfg come from.
#pragma once

#include <dynamic_reconfigure/Config.h>

#include <string>
#include <utility>
#include <vector>

#include "bsf_vpr/core/options.h"

namespace bsf_vpr {

using NamedOptionValues = std::vector<std::pair<std::string, OptionValue>>;

NamedOptionValues ValuesFromConfig(const dynamic_reconfigure::Config& config);
// Throws std::invalid_argument for a list value (dynamic_reconfigure has none).
dynamic_reconfigure::Config ConfigFromValues(const NamedOptionValues& values);

}  // namespace bsf_vpr
