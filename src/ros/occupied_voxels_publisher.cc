#include "ros/occupied_voxels_publisher.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl_conversions/pcl_conversions.h>

#include <algorithm>
#include <cmath>

namespace octo_slice_mapper {
namespace ros_adapter {

sensor_msgs::PointCloud2 occupiedVoxelsCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& frame_id,
                                             const ros::Time& stamp) {
  pcl::PCLPointCloud2 cloud;
  octo_slice_mapper::occupiedVoxelsCloud(voxels, &cloud);
  sensor_msgs::PointCloud2 msg;
  pcl_conversions::moveFromPCL(cloud, msg);
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  return msg;
}

nav_msgs::OccupancyGrid heightGrid(const HeightMap& map, const std::string& frame_id, const ros::Time& stamp) {
  nav_msgs::OccupancyGrid grid;
  grid.header.frame_id = frame_id;
  grid.header.stamp = stamp;
  grid.info.map_load_time = stamp;
  grid.info.resolution = static_cast<float>(map.resolution);
  grid.info.width = static_cast<std::uint32_t>(map.width);
  grid.info.height = static_cast<std::uint32_t>(map.height);
  grid.info.origin.position.x = map.origin_x;
  grid.info.origin.position.y = map.origin_y;
  grid.info.origin.orientation.w = 1.0;
  grid.data.assign(map.top.size(), -1);
  for (std::size_t c = 0; c < map.top.size(); ++c) {
    if (!std::isnan(map.top[c])) grid.data[c] = static_cast<std::int8_t>(std::clamp(std::lround(map.top[c] / 0.02), 0L, 100L));
    else if (!std::isnan(map.floor[c])) grid.data[c] = 0;
  }
  return grid;
}

sensor_msgs::PointCloud2 floorCells(const HeightMap& map, const std::string& frame_id, const ros::Time& stamp) {
  std::vector<float> values;
  for (int row = 0; row < map.height; ++row) {
    for (int col = 0; col < map.width; ++col) {
      const std::size_t c = std::size_t(row) * std::size_t(map.width) + std::size_t(col);
      if (std::isnan(map.floor[c])) continue;
      values.push_back(static_cast<float>(map.origin_x + (col + 0.5) * map.resolution));
      values.push_back(static_cast<float>(map.origin_y + (row + 0.5) * map.resolution));
      values.push_back(map.floor[c]);
      values.push_back(std::isnan(map.top[c]) ? 0.0f : map.top[c]);
    }
  }
  pcl::PCLPointCloud2 cloud;
  octo_slice_mapper::fourFloatCloud(values.data(), values.size() / 4, {"x", "y", "z", "top"}, &cloud);
  sensor_msgs::PointCloud2 msg;
  pcl_conversions::moveFromPCL(cloud, msg);
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  return msg;
}

OccupiedVoxelsPublisher::OccupiedVoxelsPublisher(ros::NodeHandle pnh, MappingSession* session, std::string frame_id,
                                                 double period)
    : session_(session),
      frame_id_(std::move(frame_id)),
      publisher_(pnh.advertise<sensor_msgs::PointCloud2>("occupied_voxels", 1, /*latch=*/true)),
      heights_(pnh.advertise<nav_msgs::OccupancyGrid>("height_map", 1, /*latch=*/true)),
      floor_cells_(pnh.advertise<sensor_msgs::PointCloud2>("floor_cells", 1, /*latch=*/true)),
      timer_(pnh, period, [this] { tick(); }) {}

void OccupiedVoxelsPublisher::tick() {
  const bool voxels_wanted = publisher_.getNumSubscribers() > 0;
  const bool heights_wanted = (heights_.getNumSubscribers() > 0 || floor_cells_.getNumSubscribers() > 0) &&
                              session_->floor().status().cells > 0;
  if ((!voxels_wanted && !heights_wanted) || session_->changes() == published_changes_) return;
  std::vector<OccupiedVoxel> voxels;
  std::uint64_t changes = 0;
  if (!session_->occupiedVoxels(&voxels, &changes)) return;  // a save or pass holds the map: next tick
  const ros::Time now = ros::Time::now();
  if (voxels_wanted) publisher_.publish(occupiedVoxelsCloud(voxels, frame_id_, now));
  if (heights_wanted) {
    const HeightMap map = heightMapOf(voxels, session_->floor(), session_->mapperOptions().resolution);
    if (!map.empty()) {
      if (heights_.getNumSubscribers() > 0) heights_.publish(heightGrid(map, frame_id_, now));
      if (floor_cells_.getNumSubscribers() > 0) floor_cells_.publish(floorCells(map, frame_id_, now));
    }
  }
  published_changes_ = changes;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
