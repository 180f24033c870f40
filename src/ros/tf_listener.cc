#include "ros/tf_listener.h"

#include <tf2/exceptions.h>

namespace octo_slice_mapper {
namespace ros_adapter {

TfListener::TfListener(tf2_ros::Buffer* buffer) : buffer_(buffer), spinner_(1, &callbacks_) {
  buffer_->setUsingDedicatedThread(true);  // as tf2_ros's: lookups may wait, this thread fills it
  nh_.setCallbackQueue(&callbacks_);
  tf_ = nh_.subscribe<tf2_msgs::TFMessage>(
      "/tf", kQueueSize, [this](const ros::MessageEvent<const tf2_msgs::TFMessage>& e) { received(e, false); });
  tf_static_ = nh_.subscribe<tf2_msgs::TFMessage>(
      "/tf_static", 100, [this](const ros::MessageEvent<const tf2_msgs::TFMessage>& e) { received(e, true); });
  spinner_.start();
}

TfListener::~TfListener() {
  spinner_.stop();
  tf_.shutdown();
  tf_static_.shutdown();
}

void TfListener::received(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static) {
  // Time going back (a bag restarted, /clock reset): what the buffer holds is from the future.
  // The node counts and reports jumps itself; the buffer is cleared here, as tf2_ros does.
  const ros::Time now = ros::Time::now();
  if (now < last_update_) buffer_->clear();
  last_update_ = now;
  const std::string& authority = event.getPublisherName();
  for (const geometry_msgs::TransformStamped& t : event.getMessage()->transforms) {
    try {
      buffer_->setTransform(t, authority, is_static);
    } catch (const tf2::TransformException& e) {
      ROS_ERROR_THROTTLE(10.0, "a transform from %s was refused: %s", authority.c_str(), e.what());
    }
  }
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
