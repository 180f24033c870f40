// ~occupied_voxels: the occupied voxels' centres as a sensor_msgs/PointCloud2 (x, y, z and
// occupancy, FLOAT32), the 3D map as MoveIt, 3D planners, rviz and PCL tools read it; and, once
// a depth camera found a floor, the height map on /map's lattice of cells: ~height_map, per cell
// the height of the top of what stands on the floor, as a nav_msgs/OccupancyGrid whose values are
// 2 cm steps (0-100: 0-2 m; 0 also where the floor is bare; -1 unknown), which rviz's Map display
// colours; and ~floor_cells, per cell with a floor the floor itself, exact, as a PointCloud2 (x, y
// the cell's centre, z the floor's height there, top the height above it of what stands on it,
// 0 on bare floor), which rviz shows in 3D (a ramp, a platform). All latched; published at most
// once every ~occupied_voxels_period wall seconds, only when the map changed and someone listens.
// The octree is walked on this publisher's own thread while insertion goes on
// (MappingSession::occupiedVoxels), so the scans never wait for the walk.
#pragma once

#include <ros/ros.h>
#include <nav_msgs/OccupancyGrid.h>
#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "octo_slice_mapper/internal/height_map.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapping_session.h"
#include "ros/own_thread_timer.h"

namespace octo_slice_mapper {
namespace ros_adapter {

// The voxels as occupiedVoxelsCloud (map_io.h) makes them, as a message.
sensor_msgs::PointCloud2 occupiedVoxelsCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& frame_id,
                                             const ros::Time& stamp);
// A height map's tops as ~height_map carries them.
nav_msgs::OccupancyGrid heightGrid(const HeightMap& map, const std::string& frame_id, const ros::Time& stamp);
// A height map's cells with a floor as ~floor_cells carries them (x, y, z, top: FLOAT32), row by
// row from the bottom.
sensor_msgs::PointCloud2 floorCells(const HeightMap& map, const std::string& frame_id, const ros::Time& stamp);

class OccupiedVoxelsPublisher {
 public:
  OccupiedVoxelsPublisher(ros::NodeHandle pnh, MappingSession* session, std::string frame_id, double period);

 private:
  void tick();

  MappingSession* session_;
  std::string frame_id_;
  ros::Publisher publisher_;
  ros::Publisher heights_;
  ros::Publisher floor_cells_;
  std::uint64_t published_changes_ = ~std::uint64_t{0};  // the session's changes() last published
  OwnThreadTimer timer_;  // last: ticks use all of the above
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
