// sensor_msgs/LaserScan -> core Scan, with the structural checks a driver bug can fail.
#pragma once

#include <sensor_msgs/LaserScan.h>

#include <Eigen/Geometry>
#include <string>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace ros_adapter {

// Why a whole message was refused; the key names a diagnostics counter.
struct ScanRejection {
  std::string key;      // "" when accepted
  std::string message;  // for the log
  bool rejected() const { return !key.empty(); }
};

constexpr std::size_t kMaxBeamsPerScan = 100000;

// Fills `out` from `msg` and the laser pose in the fixed frame. Single bad readings (NaN, inf,
// negative, ...) are kept for the core to classify and count; only a structurally broken message
// (empty, arrays of different lengths, impossible angles or limits, absurd size) is refused.
ScanRejection toCoreScan(const sensor_msgs::LaserScan& msg, const Eigen::Isometry3d& sensor_pose, Scan* out);

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
