#include "ros/node_parameters.h"

#include <ros/package.h>

#include <algorithm>

namespace octo_slice_mapper {
namespace ros_adapter {

MapperOptions readMapperOptions(const ros::NodeHandle& pnh) {
  MapperOptions o;
  pnh.param("resolution", o.resolution, o.resolution);
  pnh.param("clamp_min", o.clamp_min, o.clamp_min);
  pnh.param("clamp_max", o.clamp_max, o.clamp_max);
  pnh.param("max_range", o.insert.max_range, o.insert.max_range);
  pnh.param("inf_is_no_return", o.insert.readings.inf_is_no_return, o.insert.readings.inf_is_no_return);
  InverseSensorModelOptions& m = o.insert.model;
  pnh.param("beam_opening_angle", m.beam_opening_angle, m.beam_opening_angle);
  pnh.param("cone_covers_angle_step", m.cone_covers_angle_step, m.cone_covers_angle_step);
  std::string combining = o.insert.combining == EvidenceCombining::kSum ? "sum" : "occupied_wins";
  pnh.param("evidence_combining", combining, combining);
  if (combining != "sum" && combining != "occupied_wins") {
    ROS_WARN("~evidence_combining '%s' is neither 'sum' nor 'occupied_wins': using 'sum'", combining.c_str());
  }
  o.insert.combining = combining == "occupied_wins" ? EvidenceCombining::kOccupiedWins : EvidenceCombining::kSum;
  pnh.param("cone_taper_fraction", m.cone_taper_fraction, m.cone_taper_fraction);
  pnh.param("sigma_base", m.sigma_base, m.sigma_base);
  pnh.param("sigma_per_meter", m.sigma_per_meter, m.sigma_per_meter);
  pnh.param("sigma_angle_gain", m.sigma_angle_gain, m.sigma_angle_gain);
  pnh.param("p_free", m.p_free, m.p_free);
  pnh.param("p_occupied", m.p_occupied, m.p_occupied);
  pnh.param("prior", m.prior, m.prior);
  pnh.param("no_return_clear_distance", m.no_return_clear_distance, m.no_return_clear_distance);
  pnh.param("keep_scans", o.keep_scans, o.keep_scans);
  pnh.param("keyframe_min_distance", o.scan_store.min_distance, o.scan_store.min_distance);
  pnh.param("keyframe_min_rotation", o.scan_store.min_rotation, o.scan_store.min_rotation);
  pnh.param("revisit_cell", o.scan_store.revisit_cell, o.scan_store.revisit_cell);
  pnh.param("revisit_angle", o.scan_store.revisit_angle, o.scan_store.revisit_angle);
  int max_scans = static_cast<int>(o.scan_store.max_scans);
  pnh.param("max_kept_scans", max_scans, max_scans);
  o.scan_store.max_scans = static_cast<std::size_t>(std::max(0, max_scans));
  ForwardSensorModelOptions& f = o.optimizer.model;
  pnh.param("forward_z_hit", f.z_hit, f.z_hit);
  pnh.param("forward_z_rand", f.z_rand, f.z_rand);
  pnh.param("forward_z_miss", f.z_miss, f.z_miss);
  pnh.param("forward_sigma_base", f.sigma_base, f.sigma_base);
  pnh.param("forward_sigma_per_meter", f.sigma_per_meter, f.sigma_per_meter);
  pnh.param("max_sweeps", o.optimizer.max_sweeps, o.optimizer.max_sweeps);
  pnh.param("slice_min_z", o.slice.min_z, o.slice.min_z);
  pnh.param("slice_max_z", o.slice.max_z, o.slice.max_z);
  return o;
}

NodeOptions readNodeOptions(const ros::NodeHandle& pnh) {
  NodeOptions o;
  pnh.param("frame_id", o.frame_id, o.frame_id);
  pnh.param("publish_rate", o.publish_rate, o.publish_rate);
  pnh.param("publish_markers", o.publish_markers, o.publish_markers);
  pnh.param("transform_timeout", o.transform_timeout, o.transform_timeout);
  pnh.param("scan_queue_size", o.scan_queue_size, o.scan_queue_size);
  pnh.param("map_file", o.map_file, o.map_file);
  pnh.param("save_on_shutdown", o.save_on_shutdown, o.save_on_shutdown);
  pnh.param("allow_any_path", o.allow_any_path, o.allow_any_path);
  pnh.param("optimize_on_save", o.optimize_on_save, o.optimize_on_save);
  pnh.param("optimize_warm_start", o.optimize_warm_start, o.optimize_warm_start);
  pnh.param("write_optimized_into_map", o.write_optimized_into_map, o.write_optimized_into_map);
  pnh.param("online_optimize", o.online_optimize, o.online_optimize);
  pnh.param("online_optimize_period", o.online_optimize_period, o.online_optimize_period);
  const std::string package = ros::package::getPath("octo_slice_mapper");
  pnh.param("maps_dir", o.maps_dir, package.empty() ? std::string("maps") : package + "/maps");
  return o;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
