// A tf message for a planar pose (x, y, yaw) at height z, as the bag-writing tools record them.
#pragma once

#include <geometry_msgs/TransformStamped.h>

#include <cmath>
#include <string>

namespace octo_slice_mapper {
namespace tools {

inline geometry_msgs::TransformStamped planarTransform(const std::string& parent, const std::string& child,
                                                       const ros::Time& stamp, double x, double y, double z,
                                                       double yaw) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = parent;
  t.header.stamp = stamp;
  t.child_frame_id = child;
  t.transform.translation.x = x;
  t.transform.translation.y = y;
  t.transform.translation.z = z;
  t.transform.rotation.z = std::sin(0.5 * yaw);
  t.transform.rotation.w = std::cos(0.5 * yaw);
  return t;
}

}  // namespace tools
}  // namespace octo_slice_mapper
