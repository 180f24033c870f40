// /tf and /tf_static into the node's tf2 buffer, as tf2_ros::TransformListener does, but with a
// subscriber queue that outlasts a stalled node: tf2_ros's is fixed at 100 messages, 0.1 s of a 50
// Hz odometry replayed at 20x, so a 150 ms stall dropped transforms, and when that happened at the
// start, the scans of the bag's first second found no transform (real_robot_replay_test, 1 run in 3).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include <cstdint>

namespace octo_slice_mapper {
namespace ros_adapter {

class TfListener {
 public:
  // Messages of /tf that may wait for this listener's thread (tf2_ros: 100). A TFMessage of one
  // transform is ~150 bytes.
  static constexpr std::uint32_t kQueueSize = 2000;

  explicit TfListener(tf2_ros::Buffer* buffer);
  ~TfListener();
  TfListener(const TfListener&) = delete;
  TfListener& operator=(const TfListener&) = delete;

 private:
  void received(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static);

  tf2_ros::Buffer* buffer_;
  ros::NodeHandle nh_;
  ros::CallbackQueue callbacks_;  // its own, on its own thread, as tf2_ros's listener
  ros::Subscriber tf_, tf_static_;
  ros::AsyncSpinner spinner_;
  ros::Time last_update_;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
