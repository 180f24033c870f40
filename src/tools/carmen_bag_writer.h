// CARMEN log -> rosbag, so that replay.launch maps the Radish datasets in a real ROS session.
#pragma once

#include <functional>
#include <string>

#include "octo_slice_mapper/carmen_log.h"

namespace octo_slice_mapper {
namespace tools {

struct CarmenBagOptions {
  std::string scan_topic = "/scan";
  std::string fixed_frame = "odom", base_frame = "base_link", laser_frame = "laser";
  // CARMEN stamps can start near 0, which ROS reads as "unset": they are shifted by this (s).
  double time_offset = 1000.0;
};

struct CarmenBagReport {
  std::size_t scans = 0;
  std::size_t bad_lines = 0;
  std::string log_error;  // non-empty when the log ended early (the bag then holds what came before)
};

// Writes FILE.bag with /scan (sensor_msgs/LaserScan), /tf (fixed -> base at each scan's stamp: the
// log's laser pose), /tf_static (base -> laser: up by the reader's laser_z) and /odom
// (nav_msgs/Odometry). Written to FILE.partial and renamed into place when complete.
bool writeCarmenBag(CarmenLogReader* reader, const std::string& bag_path, const CarmenBagOptions& options,
                    CarmenBagReport* report, std::string* error,
                    const std::function<void(double)>& progress = {});

}  // namespace tools
}  // namespace octo_slice_mapper
