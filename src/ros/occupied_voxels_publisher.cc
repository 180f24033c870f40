#include "ros/occupied_voxels_publisher.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl_conversions/pcl_conversions.h>

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

OccupiedVoxelsPublisher::OccupiedVoxelsPublisher(ros::NodeHandle pnh, MappingSession* session, std::string frame_id,
                                                 double period)
    : session_(session),
      frame_id_(std::move(frame_id)),
      publisher_(pnh.advertise<sensor_msgs::PointCloud2>("occupied_voxels", 1, /*latch=*/true)),
      timer_(pnh, period, [this] { tick(); }) {}

void OccupiedVoxelsPublisher::tick() {
  if (publisher_.getNumSubscribers() == 0 || session_->changes() == published_changes_) return;
  std::vector<OccupiedVoxel> voxels;
  std::uint64_t changes = 0;
  if (!session_->occupiedVoxels(&voxels, &changes)) return;  // a save or pass holds the map: next tick
  publisher_.publish(occupiedVoxelsCloud(voxels, frame_id_, ros::Time::now()));
  published_changes_ = changes;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
