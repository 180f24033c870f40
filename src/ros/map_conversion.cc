#include "ros/map_conversion.h"

#include <algorithm>

namespace octo_slice_mapper {
namespace ros_adapter {

void toOccupancyGrid(const SliceGrid& slice, const std::string& frame_id, const ros::Time& stamp,
                     nav_msgs::OccupancyGrid* msg) {
  msg->header.frame_id = frame_id;
  msg->header.stamp = stamp;
  msg->info.map_load_time = stamp;
  msg->info.resolution = static_cast<float>(slice.resolution());
  msg->info.width = static_cast<std::uint32_t>(slice.width());
  msg->info.height = static_cast<std::uint32_t>(slice.height());
  msg->info.origin.position.x = slice.width() ? slice.originX() : 0.0;
  msg->info.origin.position.y = slice.height() ? slice.originY() : 0.0;
  msg->info.origin.position.z = slice.options().min_z;
  msg->info.origin.orientation.w = 1.0;
  msg->data = slice.data();
}

bool toOccupancyGridUpdate(const SliceGrid& slice, const KeyBox& box, const std::string& frame_id,
                           const ros::Time& stamp, map_msgs::OccupancyGridUpdate* msg) {
  if (box.empty() || slice.width() == 0) return false;
  const int x0 = std::max(0, int(box.min[0]) - int(slice.originKeyX()));
  const int y0 = std::max(0, int(box.min[1]) - int(slice.originKeyY()));
  const int x1 = std::min(slice.width() - 1, int(box.max[0]) - int(slice.originKeyX()));
  const int y1 = std::min(slice.height() - 1, int(box.max[1]) - int(slice.originKeyY()));
  if (x1 < x0 || y1 < y0) return false;
  msg->header.frame_id = frame_id;
  msg->header.stamp = stamp;
  msg->x = x0;
  msg->y = y0;
  msg->width = static_cast<std::uint32_t>(x1 - x0 + 1);
  msg->height = static_cast<std::uint32_t>(y1 - y0 + 1);
  msg->data.resize(std::size_t(msg->width) * msg->height);
  for (int y = y0; y <= y1; ++y) {
    const std::int8_t* row = &slice.data()[std::size_t(y) * slice.width() + x0];
    std::copy(row, row + msg->width, &msg->data[std::size_t(y - y0) * msg->width]);
  }
  return true;
}

void toOccupancyGrid(const GridImage& grid, double z, const std::string& frame_id, const ros::Time& stamp,
                     nav_msgs::OccupancyGrid* msg) {
  msg->header.frame_id = frame_id;
  msg->header.stamp = stamp;
  msg->info.map_load_time = stamp;
  msg->info.resolution = static_cast<float>(grid.resolution);
  msg->info.width = static_cast<std::uint32_t>(grid.width);
  msg->info.height = static_cast<std::uint32_t>(grid.height);
  msg->info.origin.position.x = grid.origin_x;
  msg->info.origin.position.y = grid.origin_y;
  msg->info.origin.position.z = z;
  msg->info.origin.orientation.w = 1.0;
  msg->data = grid.cells;
}

visualization_msgs::MarkerArray occupiedVoxelMarkers(const octomap::OcTree& tree, const std::string& frame_id,
                                                     const ros::Time& stamp) {
  visualization_msgs::MarkerArray array;
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame_id;
  marker.header.stamp = stamp;
  marker.ns = "occupied_voxels";
  marker.id = 0;
  marker.type = visualization_msgs::Marker::CUBE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  const double res = tree.getResolution();
  marker.scale.x = marker.scale.y = marker.scale.z = res;
  marker.color.a = 1.0;
  double min_x, min_y, min_z, max_x, max_y, max_z;
  tree.getMetricMin(min_x, min_y, min_z);
  tree.getMetricMax(max_x, max_y, max_z);
  const double z_span = std::max(res, max_z - min_z);
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    // A pruned leaf stands for a block of voxels: emit each voxel so the cubes keep one size.
    const double size = it.getSize();
    const int n = std::max(1, static_cast<int>(std::lround(size / res)));
    const double x0 = it.getX() - 0.5 * size + 0.5 * res, y0 = it.getY() - 0.5 * size + 0.5 * res,
                 z0 = it.getZ() - 0.5 * size + 0.5 * res;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < n; ++k) {
          geometry_msgs::Point p;
          p.x = x0 + i * res, p.y = y0 + j * res, p.z = z0 + k * res;
          std_msgs::ColorRGBA c;
          const double h = std::min(1.0, std::max(0.0, (p.z - min_z) / z_span));
          c.r = static_cast<float>(h), c.g = static_cast<float>(0.3 + 0.4 * (1.0 - h)), c.b = static_cast<float>(1.0 - h);
          c.a = 1.0f;
          marker.points.push_back(p);
          marker.colors.push_back(c);
        }
      }
    }
  }
  if (marker.points.empty()) marker.action = visualization_msgs::Marker::DELETEALL;
  array.markers.push_back(marker);
  return array;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
