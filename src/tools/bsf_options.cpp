// bsf_options: writes the files derived from the options tables (options.h), so that an
// option's name, default, unit, bounds and doc are declared once: cfg/Fusion.cfg (the
// dynamic_reconfigure description, from the live options), config/fusion.yaml and
// config/ingest.yaml (every parameter with its default and doc), docs/options.md (every
// option of the nodes and of bsf_evaluate). --check compares instead of writing: the test
// suite runs it, so a table changed without regenerating fails CI.
#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "bsf_vpr/core/methods.h"
#include "bsf_vpr/image/image_describer.h"
#include "bsf_vpr/io/file_util.h"
#include "src/ros/fusion/fusion_params.h"
#include "src/ros/ingest/descriptor_ingest.h"
#include "src/ros/shard/shard_params.h"
#include "src/tools/common/cli_util.h"
#include "src/tools/import/import_args.h"

namespace bsf_vpr {
namespace tools {
namespace {

const char kGenerated[] =
    "Written by bsf_options from the options tables; do not edit: change "
    "the table and run scripts/generate_options.";

std::string Usage() {
  return R"(usage: bsf_options (--write | --check) PACKAGE_DIR

Writes (or, with --check, compares with what is there) the files derived from the options
tables, below PACKAGE_DIR (the bsf_vpr source folder):
  cfg/Fusion.cfg          dynamic_reconfigure description of the fusion node's live options
  config/fusion.yaml      every fusion node parameter with its default and doc
  config/ingest.yaml      every descriptor_ingest parameter with its default and doc
  docs/options.md         every option of the nodes and of bsf_evaluate
  -h, --help              this help
Exit status: 0 when written / current, 1 when --check finds a stale file (listed), 2 on
bad arguments.
)";
}

std::string Wrapped(const std::string& text, size_t width, const std::string& prefix) {
  std::string out;
  for (const std::string& line : WrapWords(text, width)) out += prefix + line + "\n";
  return out;
}

std::string YamlValue(const OptionInfo& o) {
  if (o.type == OptionType::kExternal) return std::get<std::string>(o.default_value);
  if (const auto* list = std::get_if<std::vector<double>>(&o.default_value)) {
    std::string out = "[";
    for (size_t i = 0; i < list->size(); ++i) {
      out += (i ? ", " : "") + FormatOptionValue((*list)[i]);
    }
    return out + "]";
  }
  const std::string text = FormatOptionValue(o.default_value);
  if (std::holds_alternative<std::string>(o.default_value) &&
      (text.empty() || text.find_first_of(":#{}[],&*?|<>=!%@`'\" ") != std::string::npos ||
       text == "true" || text == "false")) {
    return "\"" + text + "\"";
  }
  return text;
}

// One line of facts about an option: unit, range, live.
std::string Facts(const OptionInfo& o) {
  std::string facts;
  const auto add = [&facts](const std::string& f) {
    if (!f.empty()) facts += (facts.empty() ? "" : "; ") + f;
  };
  if (o.live) add("live (dynamic_reconfigure)");
  add(o.unit);
  add(DescribeRange(o));
  return facts;
}

std::string Yaml(const std::string& header, const std::vector<OptionInfo>& options) {
  std::string out = Wrapped(header + " " + kGenerated, 88, "# ");
  for (const OptionInfo& o : options) {
    out += "\n" + Wrapped(o.doc, 88, "# ");
    const std::string facts = Facts(o);
    if (!facts.empty()) out += Wrapped(facts, 88, "#   ");
    out += o.name + ": " + YamlValue(o) + "\n";
  }
  return out;
}

std::string PythonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string Cfg(const std::vector<OptionInfo>& options) {
  std::string out =
      "#!/usr/bin/python3\n"
      "# The live options of the fusion node (dynamic_reconfigure): the options marked live in\n"
      "# RecognizerOptionsTable() (src/core/recognizer_options.cpp, src/core/methods.cpp).\n" +
      Wrapped(kGenerated, 88, "# ") +
      "from dynamic_reconfigure.parameter_generator_catkin import ParameterGenerator, bool_t, "
      "double_t, int_t, str_t\n\ngen = ParameterGenerator()\n";
  for (const OptionInfo& o : options) {
    std::string type = "str_t";
    if (o.type == OptionType::kBool) type = "bool_t";
    if (o.type == OptionType::kInt) type = "int_t";
    if (o.type == OptionType::kDouble) type = "double_t";
    if (o.type == OptionType::kDoubleList || o.type == OptionType::kExternal) {
      throw std::invalid_argument("option " + o.name + " cannot be live: dynamic_reconfigure " +
                                  "has no lists");
    }
    std::string edit_method;
    if (o.type == OptionType::kChoice) {
      out += o.name + "_choices = gen.enum([";
      for (size_t i = 0; i < o.choices.size(); ++i) {
        out += std::string(i ? ",\n    " : "\n    ") + "gen.const(" +
               PythonString(o.name + "_" + o.choices[i]) + ", str_t, " +
               PythonString(o.choices[i]) + ", " + PythonString(o.choices[i]) + ")";
      }
      out += "],\n    " + PythonString(o.name) + ")\n";
      edit_method = ", edit_method=" + o.name + "_choices";
    }
    std::string value;
    if (o.type == OptionType::kBool) {
      value = std::get<bool>(o.default_value) ? "True" : "False";
    } else if (o.type == OptionType::kInt || o.type == OptionType::kDouble) {
      value = FormatOptionValue(o.default_value);
    } else {
      value = PythonString(std::get<std::string>(o.default_value));
    }
    // No min or max: dynamic_reconfigure's server would clamp a value out of them before the
    // node sees it (gamma_fraction -0.5 taken as 0). The node checks the table's bounds and
    // refuses such a value, answering with the configuration in force; the doc states them.
    std::string doc = o.doc;
    const std::string facts = o.unit.empty() ? DescribeRange(o) : o.unit;
    if (!o.unit.empty() && !DescribeRange(o).empty() && o.type != OptionType::kChoice) {
      doc += " (" + o.unit + "; " + DescribeRange(o) + ")";
    } else if (!facts.empty() && o.type != OptionType::kChoice) {
      doc += " (" + facts + ")";
    }
    out += "gen.add(" + PythonString(o.name) + ", " + type + ", 0,\n        " + PythonString(doc) +
           ",\n        " + value + edit_method + ")\n";
  }
  out += "\nexit(gen.generate(\"bsf_vpr\", \"fusion\", \"Fusion\"))\n";
  return out;
}

std::string MarkdownCell(std::string text) {
  std::string out;
  for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

std::string MarkdownTable(const std::vector<OptionInfo>& options, bool flags) {
  std::string out = flags ? "| flag | default | unit; range | description |\n|---|---|---|---|\n"
                          : "| parameter | default | unit; range | description |\n"
                            "|---|---|---|---|\n";
  for (const OptionInfo& o : options) {
    if (flags && o.type == OptionType::kExternal) continue;
    const std::string name = flags ? OptionFlag(o.name) : o.name;
    std::string def = YamlValue(o);
    out += "| `" + name + "` | `" + MarkdownCell(def) + "` | " + MarkdownCell(Facts(o)) + " | " +
           MarkdownCell(o.doc) + " |\n";
  }
  return out;
}

std::string Markdown() {
  return std::string("# Options\n\n") + "<!-- " + kGenerated + " -->\n\n" +
         "Every option is declared once, with its name, default, unit, bounds and doc, in the "
         "options table of its struct (`include/bsf_vpr/core/options.h`). The ROS parameter "
         "and the command-line flag have the same name (`gamma_fraction` is "
         "`--gamma-fraction`); a parameter that no table reads is refused at start-up; the "
         "options marked live can be changed while the node runs:\n\n"
         "    rosrun dynamic_reconfigure dynparam set /bsf_vpr/fusion threshold 0.95\n\n"
         "## Fusion node (`config/fusion.yaml`)\n\n" +
         MarkdownTable(bsf_vpr::FusionParamsTable().Infos(), false) +
         "\n## Fusion shard (`launch/sharded.launch`, docs/sharding.md)\n\n"
         "A shard reads these alone (the fusion node's names for the same things); the "
         "decision's parameters are the combiner's, and a shard refuses them.\n\n" +
         MarkdownTable(bsf_vpr::ShardParamsTable().Infos(), false) +
         "\n## Descriptor ingest (`config/ingest.yaml`)\n\n" +
         MarkdownTable(bsf_vpr::IngestParamsTable().Infos(), false) +
         "\n## bsf_evaluate: method options\n\n"
         "The fusion node's parameters of the same names (`bsf_evaluate --help` lists them "
         "too).\n\n" +
         MarkdownTable(MethodOptionsTable().Infos(), true) +
         "\n## bsf_evaluate, bsf_make_reference and bsf_import: image descriptor\n\n"
         "For image folders; the descriptor_ingest parameters of the same names.\n\n" +
         MarkdownTable(ImageDescriberOptionsTable().Infos(), true) +
         "\n## bsf_import\n\n"
         "Dataset layouts to reference sets and query bags (docs/import.md); also the image "
         "descriptor flags above.\n\n" +
         MarkdownTable(bsf_vpr::tools::ImportOptionsTable().Infos(), true);
}

std::vector<std::pair<std::string, std::string>> DerivedFiles() {
  return {
      {"cfg/Fusion.cfg", Cfg(RecognizerOptionsTable().Infos(/*live_only=*/true))},
      {"config/fusion.yaml",
       Yaml("Parameters of the bsf_vpr fusion node/nodelet (its private namespace), each with "
            "its default. A parameter that is not listed here is refused at start-up. The "
            "ones marked live can be changed at run time with dynamic_reconfigure (rosrun "
            "dynamic_reconfigure dynparam set /bsf_vpr/fusion NAME VALUE). docs/options.md has "
            "them as a table.",
            bsf_vpr::FusionParamsTable().Infos())},
      {"config/ingest.yaml",
       Yaml("Parameters of the bsf_vpr descriptor_ingest node/nodelet (its private "
            "namespace), each with its default. A parameter that is not listed here is "
            "refused at start-up.",
            bsf_vpr::IngestParamsTable().Infos())},
      {"docs/options.md", Markdown()},
  };
}

int Run(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "-h" || mode == "--help") {
    std::cout << Usage();
    return 0;
  }
  if (argc != 3 || (mode != "--write" && mode != "--check")) {
    throw std::invalid_argument("usage: bsf_options --write|--check PACKAGE_DIR (see --help)");
  }
  const std::string dir = argv[2];
  int stale = 0;
  for (const auto& [path, text] : DerivedFiles()) {
    const std::string full = dir + "/" + path;
    if (mode == "--write") {
      WriteFileAtomically(full, text);
      std::cout << "bsf_options: wrote " << full << "\n";
      continue;
    }
    std::ifstream in(full, std::ios::binary);
    std::stringstream have;
    have << in.rdbuf();
    if (!in || have.str() != text) {
      std::cout << "bsf_options: " << full << " is not what the options tables give\n";
      ++stale;
    }
  }
  if (stale > 0) {
    std::cout << "bsf_options: run scripts/generate_options and commit the result\n";
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace tools
}  // namespace bsf_vpr

int main(int argc, char** argv) {
  return bsf_vpr::tools::RunTool("bsf_options", bsf_vpr::tools::Run, argc, argv);
}
