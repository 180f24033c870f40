// Shared by the rostests: waiting on a condition while spinning, and reading a grid cell.
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include <cmath>
#include <functional>

namespace octo_slice_mapper {
namespace test_support {

// Spins until `condition` holds or `seconds` (wall) pass; whether it held.
inline bool waitFor(const std::function<bool()>& condition, double seconds) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < deadline) {
    ros::spinOnce();
    if (condition()) return true;
    ros::WallDuration(0.02).sleep();
  }
  return false;
}

// The grid's value at (x, y): -2 without a grid, -1 outside it.
inline int cellOf(const nav_msgs::OccupancyGrid::ConstPtr& grid, double x, double y) {
  if (!grid) return -2;
  const auto& info = grid->info;
  const int i = static_cast<int>(std::floor((x - info.origin.position.x) / info.resolution));
  const int j = static_cast<int>(std::floor((y - info.origin.position.y) / info.resolution));
  if (i < 0 || j < 0 || i >= int(info.width) || j >= int(info.height)) return -1;
  return grid->data[std::size_t(j) * info.width + i];
}

}  // namespace test_support
}  // namespace octo_slice_mapper
