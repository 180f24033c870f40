#include "ros/parameter_reference.h"

#include <sstream>

#include "octo_slice_mapper/option_table.h"
#include "ros/node_parameters.h"

namespace octo_slice_mapper {
namespace ros_adapter {
namespace {

std::string typeOf(const OptionField& field) {
  struct Name {
    std::string operator()(const double*) const { return "double"; }
    std::string operator()(const bool*) const { return "bool"; }
    std::string operator()(const int*) const { return "int"; }
    std::string operator()(const std::size_t*) const { return "int"; }
    std::string operator()(const std::string*) const { return "string"; }
    std::string operator()(const EvidenceCombining*) const { return "`sum` \\| `occupied_wins`"; }
  };
  return std::visit(Name(), field);
}

std::string defaultOf(const char* name, const OptionField& field) {
  if (std::string(name) == "maps_dir") return "the package's `maps/`";
  const std::string text = optionValueText(field);
  return text.empty() ? "\"\"" : "`" + text + "`";
}

template <typename Options>
void rows(const std::vector<OptionSpec<Options>>& table, bool with_flag, std::ostringstream* out) {
  Options defaults;
  for (const auto& spec : table) {
    const OptionField field = spec.field(defaults);
    *out << "| `" << spec.name << "` | ";
    if (with_flag) *out << "`" << optionFlag(spec.name) << "` | ";
    *out << typeOf(field) << " | " << defaultOf(spec.name, field) << " | " << spec.unit << " | "
         << (spec.live ? "yes" : "") << " | " << spec.doc << " |\n";
  }
}

}  // namespace

std::string parameterReference() {
  std::ostringstream out;
  out << "# Parameters\n\n"
         "Generated from the option tables (`src/core/option_table.cc`, `src/ros/node_parameters.cc`) by\n"
         "`build/devel/lib/octo_slice_mapper/parameter_doc > doc/parameters.md`; do not edit by hand\n"
         "(`parameter_table_test` fails when this page and the tables differ).\n\n"
         "Each mapper option is the node's private parameter `~name` and `octo_slice_map`'s\n"
         "`--name-with-dashes` (booleans as a flag and its `--no-` form); `bench_map_quality` takes\n"
         "`--set name=value`. *Live* options can be changed while the node runs (dynamic_reconfigure:\n"
         "`rosrun rqt_reconfigure rqt_reconfigure`); the change applies to the scans that follow.\n\n"
         "## Mapper: the node and the offline tool\n\n"
         "| parameter | flag | type | default | unit | live | meaning |\n"
         "|---|---|---|---|---|---|---|\n";
  rows(mapperOptionTable(), true, &out);
  out << "\n## The node only\n\n"
         "| parameter | type | default | unit | live | meaning |\n"
         "|---|---|---|---|---|---|\n";
  rows(nodeOptionTable(), false, &out);
  return out.str();
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
