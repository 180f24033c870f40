#include "bag_scans.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include "ros/laser_scan_conversion.h"
#include "ros/point_cloud_conversion.h"

namespace octo_slice_mapper {
namespace tools {
namespace {

std::string absoluteTopic(const std::string& topic) { return topic.empty() || topic[0] == '/' ? topic : "/" + topic; }

}  // namespace

bool readBag(const std::string& path, const BagTopics& topics, const std::string& fixed_frame,
             const BagHandlers& handlers, std::map<std::string, std::size_t>* skipped, std::string* error,
             const std::function<void(double)>& progress) {
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Read);
    // Pass 1: all of the bag's tf, so a message can use transforms recorded just after it.
    rosbag::View tf_view(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static", "tf", "tf_static"}));
    const ros::Duration span = tf_view.getEndTime() - tf_view.getBeginTime();
    tf2::BufferCore buffer(span + ros::Duration(10.0));
    for (const rosbag::MessageInstance& m : tf_view) {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      if (!tf) continue;
      const bool is_static = m.getTopic().find("tf_static") != std::string::npos;
      for (const auto& t : tf->transforms) {
        try {
          buffer.setTransform(t, "bag", is_static);
        } catch (const tf2::TransformException&) {
          (*skipped)["bad_tf"]++;
        }
      }
    }
    const auto poseOf = [&](const std_msgs::Header& header, Eigen::Isometry3d* pose) {
      try {
        *pose = tf2::transformToEigen(buffer.lookupTransform(fixed_frame, header.frame_id, header.stamp));
        return true;
      } catch (const tf2::TransformException&) {
        return false;
      }
    };
    // Pass 2: the sensors' messages, in the bag's order.
    const std::string scan_topic = absoluteTopic(topics.scan), cloud_topic = absoluteTopic(topics.cloud);
    std::vector<std::string> wanted;
    for (const std::string& t : {topics.scan, scan_topic, topics.cloud, cloud_topic}) {
      if (!t.empty()) wanted.push_back(t);
    }
    rosbag::View view(bag, rosbag::TopicQuery(wanted));
    const std::size_t total = view.size();
    std::size_t seen = 0;
    for (const rosbag::MessageInstance& m : view) {
      if (progress && seen++ % 100 == 0) progress(total ? double(seen) / total : 1.0);
      const std::string topic = absoluteTopic(m.getTopic());
      Eigen::Isometry3d pose;
      if (!scan_topic.empty() && topic == scan_topic) {
        const auto msg = m.instantiate<sensor_msgs::LaserScan>();
        if (!msg) {
          (*skipped)["not_a_laser_scan"]++;
          continue;
        }
        if (!poseOf(msg->header, &pose)) {
          (*skipped)["no_transform"]++;
          continue;
        }
        Scan scan;
        const ros_adapter::ScanRejection rejection = ros_adapter::toCoreScan(*msg, pose, &scan);
        if (rejection.rejected()) {
          (*skipped)[rejection.key]++;
          continue;
        }
        if (handlers.scan) handlers.scan(scan);
      } else {
        const auto msg = m.instantiate<sensor_msgs::PointCloud2>();
        if (!msg) {
          (*skipped)["cloud_not_a_point_cloud2"]++;
          continue;
        }
        if (!poseOf(msg->header, &pose)) {
          (*skipped)["cloud_no_transform"]++;
          continue;
        }
        SensorCloud cloud;
        const ros_adapter::ScanRejection rejection = ros_adapter::toCoreCloud(*msg, pose, &cloud);
        if (rejection.rejected()) {
          (*skipped)[rejection.key]++;
          continue;
        }
        if (handlers.cloud) handlers.cloud(cloud);
      }
    }
    if (total == 0) {
      *error = path + ": no messages on topic '" + (topics.scan.empty() ? topics.cloud : topics.scan) + "'" +
               (topics.scan.empty() || topics.cloud.empty() ? "" : " nor '" + topics.cloud + "'");
      return false;
    }
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

bool readBagScans(const std::string& path, const std::string& scan_topic, const std::string& fixed_frame,
                  BagScans* out, std::string* error, const std::function<void(double)>& progress) {
  BagHandlers handlers;
  handlers.scan = [out](const Scan& scan) { out->scans.push_back(scan); };
  return readBag(path, BagTopics{scan_topic, ""}, fixed_frame, handlers, &out->skipped, error, progress);
}

}  // namespace tools
}  // namespace octo_slice_mapper
