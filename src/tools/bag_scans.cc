#include "bag_scans.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <set>

#include "ros/laser_scan_conversion.h"
#include "ros/point_cloud_conversion.h"

namespace octo_slice_mapper {
namespace tools {
namespace {

std::string absoluteTopic(const std::string& topic) { return topic.empty() || topic[0] == '/' ? topic : "/" + topic; }

// One sensor message placed through the bag's tf and converted to the core's type, then handed
// on; or the reason it is not, counted.
template <typename Msg, typename Core, typename Convert>
void placeAndHandOn(const rosbag::MessageInstance& m, const tf2::BufferCore& buffer, const std::string& fixed_frame,
                    const char* wrong_type, const char* no_transform, Convert convert,
                    const std::function<void(const Core&)>& hand_on, std::map<std::string, std::size_t>* skipped) {
  const auto msg = m.instantiate<Msg>();
  if (!msg) {
    (*skipped)[wrong_type]++;
    return;
  }
  Eigen::Isometry3d pose;
  try {
    pose = tf2::transformToEigen(buffer.lookupTransform(fixed_frame, msg->header.frame_id, msg->header.stamp));
  } catch (const tf2::TransformException&) {
    (*skipped)[no_transform]++;
    return;
  }
  Core core;
  const ros_adapter::ScanRejection rejection = convert(msg, pose, &core);
  if (rejection.rejected()) {
    (*skipped)[rejection.key]++;
    return;
  }
  if (hand_on) hand_on(core);
}

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
    // Pass 2: the sensors' messages, in the bag's order.
    std::set<std::string> scan_topics;  // absolute names
    std::vector<std::string> wanted;  // as given, and absolute (a bag may record either)
    for (const std::string& t : topics.scans) {
      if (t.empty()) continue;
      scan_topics.insert(absoluteTopic(t));
      wanted.push_back(t), wanted.push_back(absoluteTopic(t));
    }
    for (const std::string& t : topics.clouds) {
      if (!t.empty()) wanted.push_back(t), wanted.push_back(absoluteTopic(t));
    }
    if (wanted.empty()) {
      *error = "no scan or cloud topic given";
      return false;
    }
    rosbag::View view(bag, rosbag::TopicQuery(wanted));
    const std::size_t total = view.size();
    std::size_t seen = 0;
    for (const rosbag::MessageInstance& m : view) {
      if (progress && seen++ % 100 == 0) progress(total ? double(seen) / total : 1.0);
      const std::string topic = absoluteTopic(m.getTopic());
      if (scan_topics.count(topic)) {
        placeAndHandOn<sensor_msgs::LaserScan, Scan>(
            m, buffer, fixed_frame, "not_a_laser_scan", "no_transform",
            [](const sensor_msgs::LaserScan::ConstPtr& msg, const Eigen::Isometry3d& pose, Scan* out) {
              return ros_adapter::toCoreScan(*msg, pose, out);
            },
            handlers.scan, skipped);
      } else {
        placeAndHandOn<sensor_msgs::PointCloud2, DeferredCloud>(
            m, buffer, fixed_frame, "cloud_not_a_point_cloud2", "cloud_no_transform",
            [](const sensor_msgs::PointCloud2::ConstPtr& msg, const Eigen::Isometry3d& pose, DeferredCloud* out) {
              return ros_adapter::toDeferredCloud(msg, pose, out);
            },
            handlers.cloud, skipped);
      }
    }
    if (total == 0) {
      std::string names;
      std::size_t count = 0;
      for (const auto* list : {&topics.scans, &topics.clouds}) {
        for (const std::string& t : *list) {
          if (!t.empty()) names += (count++ ? ", '" : "'") + t + "'";
        }
      }
      *error = path + ": no messages on topic" + (count > 1 ? "s " : " ") + names;
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
  return readBag(path, BagTopics{{scan_topic}, {}}, fixed_frame, handlers, &out->skipped, error, progress);
}

}  // namespace tools
}  // namespace octo_slice_mapper
