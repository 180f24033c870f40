// Core map -> ROS messages: the 2D slice as OccupancyGrid, occupied voxels as markers.
#pragma once

#include <map_msgs/OccupancyGridUpdate.h>
#include <nav_msgs/OccupancyGrid.h>
#include <octomap/OcTree.h>
#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/slice_grid.h"

namespace octo_slice_mapper {
namespace ros_adapter {

void toOccupancyGrid(const SliceGrid& slice, const std::string& frame_id, const ros::Time& stamp,
                     nav_msgs::OccupancyGrid* msg);
// The slice's cells under the x-y extent of `box` (what one scan touched), as an update of the
// grid last published whole; the cost follows the box, not the map. False if the box misses the grid.
bool toOccupancyGridUpdate(const SliceGrid& slice, const KeyBox& box, const std::string& frame_id,
                           const ros::Time& stamp, map_msgs::OccupancyGridUpdate* msg);
// A raster (e.g. the optimized map) at height `z`.
void toOccupancyGrid(const GridImage& grid, double z, const std::string& frame_id, const ros::Time& stamp,
                     nav_msgs::OccupancyGrid* msg);

// One CUBE_LIST of the occupied leaves (coloured by height) for a 3D view in rviz. An empty map
// yields a DELETEALL so that rviz drops the old cubes after ~reset.
visualization_msgs::MarkerArray occupiedVoxelMarkers(const octomap::OcTree& tree, const std::string& frame_id,
                                                     const ros::Time& stamp);

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
