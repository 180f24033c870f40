#include "ros/laser_scan_conversion.h"

#include <cmath>

namespace octo_slice_mapper {
namespace ros_adapter {

ScanRejection toCoreScan(const sensor_msgs::LaserScan& msg, const Eigen::Isometry3d& sensor_pose, Scan* out) {
  const std::size_t n = msg.ranges.size();
  if (n == 0) return {"empty", "scan has no ranges"};
  if (n > kMaxBeamsPerScan) return {"too_many_beams", "scan has " + std::to_string(n) + " beams (limit " + std::to_string(kMaxBeamsPerScan) + ")"};
  if (!msg.intensities.empty() && msg.intensities.size() != n) {
    return {"length_mismatch", "ranges has " + std::to_string(n) + " entries but intensities " +
                                   std::to_string(msg.intensities.size())};
  }
  const double inc = msg.angle_increment;
  if (!std::isfinite(msg.angle_min) || !std::isfinite(msg.angle_max) || !std::isfinite(inc) || inc == 0.0) {
    return {"bad_angles", "angle_min/angle_max/angle_increment must be finite and the increment non-zero"};
  }
  // angle_max is the angle of the last beam; allow half a step of slack for drivers' rounding.
  const double expected_max = msg.angle_min + inc * static_cast<double>(n - 1);
  if (std::abs(expected_max - msg.angle_max) > 0.5 * std::abs(inc) + 1e-4) {
    return {"bad_angles", "angle_min + (n-1)*angle_increment = " + std::to_string(expected_max) +
                              " does not match angle_max = " + std::to_string(msg.angle_max)};
  }
  if (!std::isfinite(msg.range_min) || !std::isfinite(msg.range_max) || msg.range_min < 0.0f ||
      msg.range_max <= msg.range_min) {
    return {"bad_range_limits", "range_min/range_max must be finite with 0 <= range_min < range_max"};
  }
  if (!sensor_pose.matrix().allFinite()) return {"bad_transform", "sensor transform is not finite"};
  out->sensor_pose = sensor_pose;
  out->stamp = msg.header.stamp.toSec();
  out->angle_min = msg.angle_min;
  out->angle_increment = msg.angle_increment;
  out->range_min = msg.range_min;
  out->range_max = msg.range_max;
  out->ranges = msg.ranges;
  return {};
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
