#include "ros/occupied_voxels_publisher.h"

#include <sensor_msgs/PointField.h>

#include <algorithm>
#include <cstring>

namespace octo_slice_mapper {
namespace ros_adapter {

sensor_msgs::PointCloud2 occupiedVoxelsCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& frame_id,
                                             const ros::Time& stamp) {
  static_assert(sizeof(OccupiedVoxel) == 16, "four packed floats, as the fields declare");
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  msg.header.stamp = stamp;
  msg.height = 1;
  msg.width = static_cast<std::uint32_t>(voxels.size());
  const char* names[] = {"x", "y", "z", "occupancy"};
  for (std::uint32_t f = 0; f < 4; ++f) {
    sensor_msgs::PointField field;
    field.name = names[f];
    field.offset = 4 * f;
    field.datatype = sensor_msgs::PointField::FLOAT32;
    field.count = 1;
    msg.fields.push_back(field);
  }
  msg.is_bigendian = false;
  msg.point_step = sizeof(OccupiedVoxel);
  msg.row_step = msg.point_step * msg.width;
  msg.is_dense = true;
  msg.data.resize(voxels.size() * sizeof(OccupiedVoxel));
  if (!voxels.empty()) std::memcpy(msg.data.data(), voxels.data(), msg.data.size());
  return msg;
}

OccupiedVoxelsPublisher::OccupiedVoxelsPublisher(ros::NodeHandle pnh, MappingSession* session, std::string frame_id,
                                                 double period)
    : session_(session), frame_id_(std::move(frame_id)) {
  ros::NodeHandle own(pnh);
  own.setCallbackQueue(&queue_);
  publisher_ = own.advertise<sensor_msgs::PointCloud2>("occupied_voxels", 1, /*latch=*/true);
  timer_ = own.createWallTimer(ros::WallDuration(std::max(0.05, period)), &OccupiedVoxelsPublisher::tick, this);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

OccupiedVoxelsPublisher::~OccupiedVoxelsPublisher() {
  timer_.stop();
  spinner_->stop();
}

void OccupiedVoxelsPublisher::tick(const ros::WallTimerEvent&) {
  if (publisher_.getNumSubscribers() == 0 || session_->changes() == published_changes_) return;
  std::vector<OccupiedVoxel> voxels;
  std::uint64_t changes = 0;
  if (!session_->occupiedVoxels(&voxels, &changes)) return;  // a save or pass holds the map: next tick
  publisher_.publish(occupiedVoxelsCloud(voxels, frame_id_, ros::Time::now()));
  published_changes_ = changes;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
