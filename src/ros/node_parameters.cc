#include "ros/node_parameters.h"

#include <ros/package.h>

#include <algorithm>
#include <variant>
#include <vector>

namespace octo_slice_mapper {
namespace ros_adapter {
namespace {

// Reads ~NAME into the field, keeping its value as the default.
void readParameter(const ros::NodeHandle& pnh, const char* name, const OptionField& field) {
  // A list of names (the topic lists) into a string option: its items separated by spaces.
  XmlRpc::XmlRpcValue list;
  if (std::holds_alternative<std::string*>(field) && pnh.getParam(name, list) &&
      list.getType() == XmlRpc::XmlRpcValue::TypeArray) {
    std::string joined;
    for (int i = 0; i < list.size(); ++i) {
      if (list[i].getType() == XmlRpc::XmlRpcValue::TypeString) {
        joined += (joined.empty() ? "" : " ") + static_cast<std::string>(list[i]);
      } else {
        ROS_WARN("~%s: item %d is not a string: left out", name, i);
      }
    }
    *std::get<std::string*>(field) = joined;
    return;
  }
  struct Read {
    const ros::NodeHandle& pnh;
    const char* name;
    void operator()(double* v) const { pnh.param(name, *v, *v); }
    void operator()(bool* v) const { pnh.param(name, *v, *v); }
    void operator()(int* v) const { pnh.param(name, *v, *v); }
    void operator()(std::string* v) const { pnh.param(name, *v, *v); }
    void operator()(std::size_t* v) const {
      int value = static_cast<int>(*v);
      pnh.param(name, value, value);
      *v = static_cast<std::size_t>(std::max(0, value));
    }
    void operator()(EvidenceCombining* v) const {
      std::string text = evidenceCombiningName(*v);
      pnh.param(name, text, text);
      if (!evidenceCombiningFromName(text, v)) {
        ROS_WARN("~%s '%s' is neither 'sum' nor 'occupied_wins': using '%s'", name, text.c_str(),
                 evidenceCombiningName(*v));
      }
    }
  };
  std::visit(Read{pnh, name}, field);
}

}  // namespace

const std::vector<OptionSpec<NodeOptions>>& nodeOptionTable() {
  using O = NodeOptions;
  static const std::vector<OptionSpec<NodeOptions>> table = {
      {"scan_topics", "", "LaserScan topics, one per lidar (a list, or names separated by spaces)",
       [](O& o) -> OptionField { return &o.scan_topics; }},
      {"cloud_topics", "", "PointCloud2 topics, one per depth camera (a list, or names separated by spaces)",
       [](O& o) -> OptionField { return &o.cloud_topics; }},
      {"frame_id", "", "fixed frame of the map", [](O& o) -> OptionField { return &o.frame_id; }},
      {"floor_base_frame", "",
       "a frame whose origin lies on the floor the robot stands on: each depth frame's floor is the one through it, so "
       "that no table and no floor below an edge (a stairwell) is taken for it; \"auto\" = base_footprint where tf "
       "has it (REP 120), else none; \"\" = none (the floor found from the points alone, as for a hand-held camera)",
       [](O& o) -> OptionField { return &o.floor_base_frame; }},
      {"publish_rate", "Hz", "the whole map is published this often when it changed",
       [](O& o) -> OptionField { return &o.publish_rate; }, true},
      {"publish_markers", "", "publish ~occupied_cells", [](O& o) -> OptionField { return &o.publish_markers; }},
      {"occupied_voxels_period", "s", "~occupied_voxels is published at most this often, when the map changed and someone listens",
       [](O& o) -> OptionField { return &o.occupied_voxels_period; }},
      {"transform_timeout", "s", "how long a message may wait for its transform",
       [](O& o) -> OptionField { return &o.transform_timeout; }},
      {"scan_queue_size", "", "scans queued for the node and held while waiting for tf (a full queue drops the oldest)", [](O& o) -> OptionField { return &o.scan_queue_size; }},
      {"map_file", "", ".bt/.ot to resume from", [](O& o) -> OptionField { return &o.map_file; }},
      {"save_on_shutdown", "", "prefix written when the node stops", [](O& o) -> OptionField { return &o.save_on_shutdown; }},
      {"maps_dir", "", "where ~save_map writes", [](O& o) -> OptionField { return &o.maps_dir; }},
      {"allow_any_path", "", "let ~save_map write outside maps_dir", [](O& o) -> OptionField { return &o.allow_any_path; }},
      {"optimize_on_save", "", "a save runs the global pass and writes its map as PREFIX.* (false: the incremental map)", [](O& o) -> OptionField { return &o.optimize_on_save; }},
      {"optimize_warm_start", "", "the pass starts from the incremental map",
       [](O& o) -> OptionField { return &o.optimize_warm_start; }},
      {"write_optimized_into_map", "", "the pass's result goes into the octree's slice band",
       [](O& o) -> OptionField { return &o.write_optimized_into_map; }},
      {"online_optimize", "", "keep running the global pass in the background",
       [](O& o) -> OptionField { return &o.online_optimize; }},
      {"online_optimize_period", "s", "between looks for a finished pass and a changed map",
       [](O& o) -> OptionField { return &o.online_optimize_period; }},
      {"online_optimize_threads", "", "worker threads of the background pass (0 = every core)",
       [](O& o) -> OptionField { return &o.online_optimize_threads; }},
      {"cloud_threads", "", "workers preparing point clouds, frames in parallel, applied in arrival order (0 = every core)",
       [](O& o) -> OptionField { return &o.cloud_threads; }},
  };
  return table;
}

std::vector<std::string> topicNames(const std::string& list) {
  std::vector<std::string> names;
  std::string name;
  for (std::size_t k = 0; k <= list.size(); ++k) {
    const char c = k < list.size() ? list[k] : ' ';
    if (c != ' ' && c != ',' && c != '\t' && c != '\n') {
      name += c;
      continue;
    }
    if (!name.empty() && std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    name.clear();
  }
  return names;
}

MapperOptions readMapperOptions(const ros::NodeHandle& pnh) {
  MapperOptions o;
  for (const auto& spec : mapperOptionTable()) readParameter(pnh, spec.name, spec.field(o));
  return o;
}

NodeOptions readNodeOptions(const ros::NodeHandle& pnh) {
  NodeOptions o;
  const std::string package = ros::package::getPath("octo_slice_mapper");
  o.maps_dir = package.empty() ? std::string("maps") : package + "/maps";
  for (const auto& spec : nodeOptionTable()) readParameter(pnh, spec.name, spec.field(o));
  return o;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
