// The ROS face of the mapper: scans and clouds in through tf2, the map out, services beside. The
// node only takes messages in (waiting for their transform, in arrival order), converts them to
// core types for the MappingSession, and wires the adapters: MapPublisher (outputs),
// MapperServices (services), OnlinePass (the background global pass), diagnostics. Messages are
// handled in order on the global callback queue; the services have a queue of their own.
#pragma once

#include <message_filters/subscriber.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "octo_slice_mapper/cloud_pipeline.h"
#include "octo_slice_mapper/mapping_session.h"
#include "ros/diagnostics.h"
#include "ros/live_reconfigure.h"
#include "ros/map_publisher.h"
#include "ros/mapper_services.h"
#include "ros/node_parameters.h"
#include "ros/occupied_voxels_publisher.h"
#include "ros/online_pass.h"
#include "ros/pending_messages.h"
#include "ros/tf_listener.h"
#include "ros/sequence_gaps.h"

namespace octo_slice_mapper {
namespace ros_adapter {

class MapperNode {
 public:
  MapperNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  // Writes ~save_on_shutdown (if set) and logs the session summary.
  void shutdown();
  std::string summary();

 private:
  // One input topic (scans or clouds): subscriber, tf filter, and the messages waiting in order.
  template <typename M>
  struct Input {
    std::string topic;  // as resolved
    message_filters::Subscriber<M> subscriber;
    std::unique_ptr<tf2_ros::MessageFilter<M>> filter;
    PendingMessages<M, Eigen::Isometry3d> waiting;
    SequenceGaps sequence;  // what never arrived
  };
  // One input per topic of `topics` (topicNames), each subscribed with its own tf filter.
  template <typename M>
  void connectAll(const std::string& topics, std::uint32_t queue, const ros::TransportHints& hints,
                  std::vector<std::unique_ptr<Input<M>>>* inputs);
  template <typename M>
  void connect(const std::string& topic, std::uint32_t queue, const ros::TransportHints& hints, Input<M>* input);
  // Inserts the messages whose turn it is (see PendingMessages).
  template <typename M>
  void handleReady(Input<M>* input);
  template <typename M>
  void insert(const boost::shared_ptr<const M>& msg, const Eigen::Isometry3d& pose, const std::string& topic);
  template <typename M>
  bool transformThere(const boost::shared_ptr<const M>& msg);
  // The sensor's pose at the message's stamp, if tf has it (without the cost of an exception if not).
  template <typename M>
  bool poseIfThere(const boost::shared_ptr<const M>& msg, Eigen::Isometry3d* pose);
  template <typename M>
  void expireWaiting(Input<M>* input);
  template <typename M>
  void onTransformFailure(const boost::shared_ptr<const M>& msg, tf2_ros::FilterFailureReason reason);
  // A current message "older than the tf buffer": the clock jumped back unnoticed.
  void clearTfIfFromTheFuture(const std_msgs::Header& header, tf2_ros::FilterFailureReason reason);
  // False (and `why`) when tf has no transform at the header's stamp.
  bool sensorPose(const std_msgs::Header& header, Eigen::Isometry3d* pose, std::string* why);
  // The ground point of a cloud stamped `stamp` (floorBaseOf(floor_base_frame)'s origin in the map
  // frame); none where there is none, with a throttled warning where a named frame cannot be placed.
  std::optional<Eigen::Vector3d> groundAt(const ros::Time& stamp);
  // After a message's insertion (on a cloud worker for clouds): its counters, and the map's
  // change published.
  template <typename M>
  void inserted(const CloudPipeline::Outcome& outcome, const ros::Time& stamp, const std::string& topic);
  void skip(const std::string& reason, const std::string& message);
  // A message stamped 0 is skipped as zero_stamp (true).
  bool stampedZero(const std_msgs::Header& header);
  // A message stamped well before the last one: a bag restarted (--loop) or /clock reset.
  void checkTimeJump(const ros::Time& stamp);
  void expireTick(const ros::WallTimerEvent&);
  void publishDiagnostics(const ros::WallTimerEvent&);

  ros::NodeHandle nh_, pnh_;
  NodeOptions options_;
  MappingSession session_;
  tf2_ros::Buffer tf_buffer_;
  TfListener tf_listener_;
  std::vector<std::unique_ptr<Input<sensor_msgs::LaserScan>>> scans_;  // one per scan topic
  std::vector<std::unique_ptr<Input<sensor_msgs::PointCloud2>>> clouds_;
  MapPublisher publisher_;
  ros::Publisher diagnostics_pub_;
  ros::WallTimer publish_timer_, diagnostics_timer_;
  ros::WallTimer expire_timer_;

  mutable std::mutex counters_mutex_;  // guards the counters and what follows
  NodeCounters counters_;              // map sizes filled in when reported
  SkipLog skip_log_;
  NodeCounters at_last_report_;  // as of the last /diagnostics report: what is new since (its timer only)
  ros::Time last_stamp_;
  ros::WallTime started_;
  // Last: their threads use the session and the publisher until they are destroyed.
  std::unique_ptr<OnlinePass> online_pass_;
  std::unique_ptr<OccupiedVoxelsPublisher> voxels_publisher_;
  std::unique_ptr<MapperServices> services_;
  std::unique_ptr<LiveReconfigure> reconfigure_;
  std::unique_ptr<CloudPipeline> cloud_pipeline_;  // first destroyed: its workers publish and count
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
