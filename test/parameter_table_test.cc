// The option tables are the one source of the parameters: doc/parameters.md is generated from
// them (and must be current), each option is named once, and cfg/Mapper.cfg (dynamic_reconfigure)
// offers exactly the tables' live options, with their defaults.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "octo_slice_mapper/option_table.h"
#include "ros/node_parameters.h"
#include "ros/parameter_reference.h"

using namespace octo_slice_mapper;

namespace {

std::string fileText(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(ParameterTable, TheCommittedReferenceIsTheGeneratedOne) {
  const std::string generated = ros_adapter::parameterReference();
  const std::string committed = fileText(std::string(OSM_SOURCE_DIR) + "/doc/parameters.md");
  EXPECT_EQ(committed, generated) << "doc/parameters.md is out of date: regenerate it with "
                                     "build/devel/lib/octo_slice_mapper/parameter_doc > doc/parameters.md";
  for (const auto& spec : mapperOptionTable()) {
    EXPECT_NE(generated.find(std::string("| `") + spec.name + "` | `" + optionFlag(spec.name) + "` |"), std::string::npos)
        << spec.name;
  }
  for (const auto& spec : ros_adapter::nodeOptionTable()) {
    EXPECT_NE(generated.find(std::string("| `") + spec.name + "` |"), std::string::npos) << spec.name;
  }
}

TEST(ParameterTable, OptionValuesReadBackFromTheirText) {
  MapperOptions o;
  for (const auto& spec : mapperOptionTable()) {
    MapperOptions copy;
    const std::string text = optionValueText(spec.field(o));
    EXPECT_TRUE(setOptionFromText(spec.field(copy), text)) << spec.name << " = " << text;
    EXPECT_EQ(optionValueText(spec.field(copy)), text) << spec.name;
  }
  double d = 1.0;
  EXPECT_FALSE(setOptionFromText(OptionField(&d), "0.5x"));
  EXPECT_FALSE(setOptionFromText(OptionField(&d), ""));
  EXPECT_EQ(d, 1.0);
  EvidenceCombining c = EvidenceCombining::kSum;
  EXPECT_FALSE(setOptionFromText(OptionField(&c), "max"));
  EXPECT_TRUE(setOptionFromText(OptionField(&c), "occupied_wins"));
  EXPECT_EQ(c, EvidenceCombining::kOccupiedWins);
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

// cfg/Mapper.cfg (dynamic_reconfigure) offers exactly the live options of the tables, with their
// defaults.
TEST(ParameterTable, TheReconfigureConfigOffersTheLiveOptionsWithTheirDefaults) {
  const std::string text = fileText(std::string(OSM_SOURCE_DIR) + "/cfg/Mapper.cfg");
  std::regex add_re(R"re(\.add\("([a-z_0-9]+)",\s*double_t,\s*0,\s*"[^"]*",\s*([-0-9.e]+),)re");
  std::map<std::string, std::string> live;  // name -> default
  MapperOptions m;
  for (const auto& spec : mapperOptionTable()) {
    if (spec.live) live[spec.name] = optionValueText(spec.field(m));
  }
  ros_adapter::NodeOptions n;
  for (const auto& spec : ros_adapter::nodeOptionTable()) {
    if (spec.live) live[spec.name] = optionValueText(spec.field(n));
  }
  std::set<std::string> offered;
  for (std::sregex_iterator it(text.begin(), text.end(), add_re), end; it != end; ++it) {
    const std::string name = (*it)[1];
    offered.insert(name);
    ASSERT_TRUE(live.count(name)) << name << " is in Mapper.cfg but no table marks it live";
    EXPECT_DOUBLE_EQ(std::atof((*it)[2].str().c_str()), std::atof(live[name].c_str())) << name;
  }
  for (const auto& kv : live) EXPECT_TRUE(offered.count(kv.first)) << kv.first << " is live but not in Mapper.cfg";
}

}  // namespace
