// Every option of the mapper named once: name, unit, what it does, and the field of MapperOptions
// it sets; the default is the field's value in MapperOptions{}. The node reads each as its
// ~parameter, octo_slice_map as --name-with-dashes (with CLI11), bench_map_quality with --set,
// and doc/parameters.md is generated from it (parameter_doc; a test keeps the page current).
// Adding an option = one line here.
#pragma once

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "octo_slice_mapper/mapper.h"

namespace octo_slice_mapper {

// Where an option's value lives. An enum option is read and written as its name.
using OptionField = std::variant<double*, bool*, int*, std::size_t*, std::string*, EvidenceCombining*>;

template <typename Options>
struct OptionSpec {
  const char* name;  // the ROS parameter; the command line has it with dashes
  const char* unit;  // "" for none
  const char* doc;
  std::function<OptionField(Options&)> field;
  // rqt_reconfigure can change it in a running node (cfg/Mapper.cfg lists exactly these).
  bool live = false;
};

const std::vector<OptionSpec<MapperOptions>>& mapperOptionTable();

// "sum" / "occupied_wins"; false for any other name.
bool evidenceCombiningFromName(const std::string& name, EvidenceCombining* out);
const char* evidenceCombiningName(EvidenceCombining combining);
// The field's value as text: numbers as %g, booleans true/false, enums by name.
std::string optionValueText(const OptionField& field);
// Sets the field from text as optionValueText writes it; false (the field unchanged) for text that
// is not such a value.
bool setOptionFromText(const OptionField& field, const std::string& text);
// The command-line flag of an option: "--" and the name with '_' as '-'.
std::string optionFlag(const char* name);

}  // namespace octo_slice_mapper
