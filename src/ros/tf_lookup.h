// One transform from a tf2 buffer (the node's, or a bag reader's), as an Eigen pose or none.
#pragma once

#include <ros/time.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>

#include <Eigen/Geometry>
#include <optional>
#include <string>

namespace octo_slice_mapper {
namespace ros_adapter {

// Frame `source`'s pose in frame `target` at `stamp`; none where tf cannot give it (`why`, when
// given, then holds tf's reason). Callers decide what a missing transform means: a message
// skipped, or a cloud mapped without its ground point.
inline std::optional<Eigen::Isometry3d> lookupPose(const tf2::BufferCore& tf, const std::string& target,
                                                   const std::string& source, const ros::Time& stamp,
                                                   std::string* why = nullptr) {
  try {
    return tf2::transformToEigen(tf.lookupTransform(target, source, stamp));
  } catch (const tf2::TransformException& e) {
    if (why) *why = e.what();
    return std::nullopt;
  }
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
