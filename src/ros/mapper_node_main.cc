// mapper_node: mapping with known poses from LaserScan (and optional PointCloud2) into an OctoMap.
#include <ros/ros.h>

#include "core/internal/memory_reuse.h"
#include "ros/mapper_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "mapper_node");
  // Each frame's few megabytes reused rather than faulted in again (memory_reuse.h).
  octo_slice_mapper::keepFreedMemoryForReuse();
  ros::NodeHandle nh, pnh("~");
  try {
    octo_slice_mapper::ros_adapter::MapperNode node(nh, pnh);
    ros::spin();
    node.shutdown();
  } catch (const std::exception& e) {
    ROS_FATAL("mapper_node: %s", e.what());
    return 1;
  }
  return 0;
}
