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

// The `floor_base_frame` setting read: "auto" is REP 120's base_footprint where tf has that frame
// (a robot's), and quietly none where it has not (a hand-held camera's tf); "" is none; any other
// name is that frame, asked for every cloud.
struct FloorBase {
  std::string frame;      // "": no ground point
  bool required = false;  // a cloud tf cannot place `frame` for is worth a warning
};

inline FloorBase floorBaseOf(const std::string& setting) {
  if (setting == "auto") return {"base_footprint", false};
  return {setting, !setting.empty()};
}

// The ground point of a cloud stamped `stamp`: `base`'s origin in `fixed`, or none (`why`, when
// given, says why where a frame was asked for and tf could not give it).
inline std::optional<Eigen::Vector3d> groundPoint(const tf2::BufferCore& tf, const std::string& fixed,
                                                  const FloorBase& base, const ros::Time& stamp,
                                                  std::string* why = nullptr) {
  if (base.frame.empty() || (!base.required && !tf._frameExists(base.frame))) return std::nullopt;
  if (const std::optional<Eigen::Isometry3d> pose = lookupPose(tf, fixed, base.frame, stamp, why)) {
    return pose->translation();
  }
  return std::nullopt;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
