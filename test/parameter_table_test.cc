// The README's parameter table against the option tables (issue 20): every option is there with
// its default, and every row names an option that exists.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <algorithm>
#include <sstream>

#include "octo_slice_mapper/option_table.h"
#include "ros/node_parameters.h"

using namespace octo_slice_mapper;

namespace {

// name -> default as the README writes it, from the rows of the table headed
// "| parameter | default | meaning |"; a row may name several options with as many defaults.
std::map<std::string, std::string> readmeParameters() {
  std::ifstream in(std::string(OSM_SOURCE_DIR) + "/README.md");
  std::map<std::string, std::string> out;
  std::string line;
  bool in_table = false;
  while (std::getline(in, line)) {
    if (line.rfind("| parameter | default |", 0) == 0) in_table = true;
    else if (in_table && line.rfind("|", 0) != 0) in_table = false;
    if (!in_table || line.rfind("| `", 0) != 0) continue;
    const std::size_t second = line.find('|', 1), third = line.find('|', second + 1);
    const std::string names = line.substr(1, second - 1), defaults = line.substr(second + 1, third - second - 1);
    std::vector<std::string> parts;
    std::stringstream split(defaults);
    for (std::string part; std::getline(split, part, ',');) parts.push_back(part);
    std::regex name_re("`([a-z_0-9]+)`");
    std::size_t k = 0;
    for (std::sregex_iterator it(names.begin(), names.end(), name_re), end; it != end; ++it, ++k) {
      std::string value = k < parts.size() ? parts[k] : "";
      value.erase(std::remove(value.begin(), value.end(), '`'), value.end());
      std::stringstream words(value);
      std::string first;
      words >> first;  // "0.02 m" -> "0.02"
      out[(*it)[1]] = first;
    }
  }
  return out;
}

template <typename Options>
void expectDocumented(const std::vector<OptionSpec<Options>>& table, std::map<std::string, std::string>* readme) {
  Options defaults;
  for (const auto& spec : table) {
    const auto row = readme->find(spec.name);
    if (row == readme->end()) {
      ADD_FAILURE() << spec.name << " is not in the README's parameter table";
      continue;
    }
    const std::string value = optionValueText(spec.field(defaults));
    char* end = nullptr;
    const double readme_number = std::strtod(row->second.c_str(), &end);
    if (std::string(spec.name) == "maps_dir") {
      // its default is found at run time: the package's maps/ folder
    } else if (end != row->second.c_str() && *end == '\0') {
      EXPECT_DOUBLE_EQ(readme_number, std::atof(value.c_str())) << spec.name;
    } else {
      EXPECT_EQ(row->second == "\"\"" ? "" : row->second, value) << spec.name;
    }
    readme->erase(row);
  }
}

TEST(ParameterTable, TheReadmeListsEveryOptionWithItsDefaultAndNoOther) {
  std::map<std::string, std::string> readme = readmeParameters();
  ASSERT_GT(readme.size(), 30u) << "the README's parameter table was not found";
  expectDocumented(mapperOptionTable(), &readme);
  expectDocumented(ros_adapter::nodeOptionTable(), &readme);
  for (const auto& row : readme) ADD_FAILURE() << "the README documents `" << row.first << "`, which no table has";
}

TEST(ParameterTable, EveryOptionIsNamedOnceAndSetsItsOwnField) {
  std::set<std::string> names;
  std::set<const void*> fields;
  MapperOptions o;
  for (const auto& spec : mapperOptionTable()) {
    EXPECT_TRUE(names.insert(spec.name).second) << spec.name << " twice";
    const void* field = std::visit([](auto* p) { return static_cast<const void*>(p); }, spec.field(o));
    EXPECT_TRUE(fields.insert(field).second) << spec.name << " sets a field another option sets";
  }
  ros_adapter::NodeOptions n;
  for (const auto& spec : ros_adapter::nodeOptionTable()) {
    EXPECT_TRUE(names.insert(spec.name).second) << spec.name << " twice";
  }
  EXPECT_EQ(optionFlag("no_return_clear_distance"), "--no-return-clear-distance");
}

}  // namespace

namespace {

// cfg/Mapper.cfg (dynamic_reconfigure) names options of the tables, with their defaults.
TEST(ParameterTable, TheReconfigureConfigUsesTheTablesNamesAndDefaults) {
  std::ifstream in(std::string(OSM_SOURCE_DIR) + "/cfg/Mapper.cfg");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::regex add_re(R"re(\.add\("([a-z_0-9]+)",\s*double_t,\s*0,\s*"[^"]*",\s*([-0-9.e]+),)re");
  std::map<std::string, std::string> defaults;
  MapperOptions m;
  for (const auto& spec : mapperOptionTable()) defaults[spec.name] = optionValueText(spec.field(m));
  ros_adapter::NodeOptions n;
  for (const auto& spec : ros_adapter::nodeOptionTable()) defaults[spec.name] = optionValueText(spec.field(n));
  std::size_t found = 0;
  for (std::sregex_iterator it(text.begin(), text.end(), add_re), end; it != end; ++it, ++found) {
    const std::string name = (*it)[1];
    ASSERT_TRUE(defaults.count(name)) << name << " is in Mapper.cfg but in no option table";
    EXPECT_DOUBLE_EQ(std::atof((*it)[2].str().c_str()), std::atof(defaults[name].c_str())) << name;
  }
  EXPECT_GE(found, 16u) << "Mapper.cfg's parameters were not found";
}

}  // namespace
