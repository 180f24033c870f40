#include "ros/mapper_node.h"

#include <cstdio>
#include <type_traits>

#include "octo_slice_mapper/map_io.h"
#include "core/internal/thread_cpu_time.h"
#include "ros/laser_scan_conversion.h"
#include "ros/point_cloud_conversion.h"
#include "ros/tf_lookup.h"

namespace octo_slice_mapper {
namespace ros_adapter {
namespace {

// What differs between the two kinds of input; everything else is one code path.
template <typename M>
struct Kind;
template <>
struct Kind<sensor_msgs::LaserScan> {
  using Core = Scan;
  static constexpr const char* kName = "scan";
  static constexpr const char* kInvalid = "invalid_scan";
  static std::uint64_t& received(NodeCounters& c) { return c.scans_received; }
  static std::uint64_t& missed(NodeCounters& c) { return c.scans_missed; }
  static std::uint64_t& lost(NodeCounters& c) { return c.scans_lost; }
  static std::uint64_t& inserted(NodeCounters& c) { return c.scans_inserted; }
  static double& seconds(NodeCounters& c) { return c.scan_insert_seconds; }
  static double& cpuSeconds(NodeCounters& c) { return c.scan_insert_cpu_seconds; }
  static ScanRejection toCore(const sensor_msgs::LaserScan::ConstPtr& m, const Eigen::Isometry3d& pose, Scan* out) {
    return toCoreScan(*m, pose, out);
  }
};
template <>
struct Kind<sensor_msgs::PointCloud2> {
  using Core = DeferredCloud;
  static constexpr const char* kName = "point cloud";
  static constexpr const char* kInvalid = "invalid_cloud";
  static std::uint64_t& received(NodeCounters& c) { return c.clouds_received; }
  static std::uint64_t& missed(NodeCounters& c) { return c.clouds_missed; }
  static std::uint64_t& lost(NodeCounters& c) { return c.clouds_lost; }
  static std::uint64_t& inserted(NodeCounters& c) { return c.clouds_inserted; }
  static double& seconds(NodeCounters& c) { return c.cloud_insert_seconds; }
  static double& cpuSeconds(NodeCounters& c) { return c.cloud_insert_cpu_seconds; }
  // Only the layout is checked here; the points are converted into the map frame on the cloud
  // pipeline's worker that prepares the frame.
  static ScanRejection toCore(const sensor_msgs::PointCloud2::ConstPtr& m, const Eigen::Isometry3d& pose,
                              DeferredCloud* out) {
    return toDeferredCloud(m, pose, out);
  }
};

SessionOptions sessionOptionsOf(const NodeOptions& o) {
  SessionOptions s;
  s.optimize_on_save = o.optimize_on_save;
  s.warm_start = o.optimize_warm_start;
  s.write_optimized_into_map = o.write_optimized_into_map;
  return s;
}

}  // namespace

MapperNode::MapperNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readNodeOptions(pnh)),
      session_(readMapperOptions(pnh), sessionOptionsOf(options_)),
      tf_listener_(&tf_buffer_),
      publisher_(nh, pnh, options_.frame_id, options_.publish_markers),
      started_(ros::WallTime::now()) {
  if (!options_.map_file.empty()) {
    std::string error;
    if (session_.load(options_.map_file, &error)) {
      ROS_INFO("resumed map %s", options_.map_file.c_str());
      const MapSetCheck set = checkMapSet(mapSetPrefixOf(options_.map_file));
      if (set.mixed()) {
        ROS_WARN("~map_file's set is mixed, a save was killed between renaming its files: %s. The map was read "
                 "from %s alone, which is whole.", set.describe().c_str(), options_.map_file.c_str());
      }
    } else {
      ROS_ERROR("could not load ~map_file: %s; starting with an empty map", error.c_str());
    }
  }
  // What saves killed mid-write left in maps_dir (each set's final names are whole; doc/bad-input.md).
  if (const std::size_t stale = removeStaleTemporariesIn(options_.maps_dir)) {
    ROS_INFO("removed %zu temporary files a killed save had left in %s", stale, options_.maps_dir.c_str());
  }
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 5);
  connectAll(options_.scan_topics, static_cast<std::uint32_t>(std::max(1, options_.scan_queue_size)),
             ros::TransportHints().tcpNoDelay(), &scans_);
  connectAll(options_.cloud_topics, 5, ros::TransportHints(), &clouds_);
  if (scans_.empty() && clouds_.empty()) ROS_WARN("~scan_topics and ~cloud_topics are both empty: nothing to map");
  expire_timer_ = nh_.createWallTimer(ros::WallDuration(0.05), &MapperNode::expireTick, this);
  // Wall-clock periods: what they pace is work and bandwidth, which a bag replayed at 20x must not
  // multiply (on ROS time both fired 20 times as often, and the diagnostics' tree walks took an
  // eighth of the scan thread).
  publish_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / std::max(0.1, options_.publish_rate)),
                                       [this](const ros::WallTimerEvent&) { publisher_.publishIfChanged(session_, ros::Time::now()); });
  diagnostics_timer_ = nh_.createWallTimer(ros::WallDuration(1.0), &MapperNode::publishDiagnostics, this);
  const MapperOptions& mapper = session_.mapperOptions();
  if (options_.online_optimize && mapper.keep_scans) {
    online_pass_ = std::make_unique<OnlinePass>(
        pnh_, mapper.optimizer, mapper.resolution,
        mapper.slice.min_z, options_.frame_id, options_.online_optimize_period,
        [this] {
          std::optional<OnlineOptimizerInput> input = session_.onlinePassInput();
          if (input && input->options) input->options->threads = options_.online_optimize_threads;
          return input;
        },
        [this](const nav_msgs::OccupancyGrid& grid) { publisher_.publishBest(grid); });
  }
  voxels_publisher_ =
      std::make_unique<OccupiedVoxelsPublisher>(pnh_, &session_, options_.frame_id, options_.occupied_voxels_period);
  cloud_pipeline_ = std::make_unique<CloudPipeline>(&session_, static_cast<unsigned>(std::max(0, options_.cloud_threads)),
                                                    /*max_pending=*/4);
  services_ = std::make_unique<MapperServices>(nh_, pnh_, options_, &session_, &publisher_, online_pass_.get());
  reconfigure_ = std::make_unique<LiveReconfigure>(
      pnh_, &session_, [this](double rate) { publish_timer_.setPeriod(ros::WallDuration(1.0 / std::max(0.1, rate))); },
      std::function<void()>());
  ROS_INFO("mapping in frame '%s' at %.3f m, slice z [%.2f, %.2f] m", options_.frame_id.c_str(), mapper.resolution,
           mapper.slice.min_z, mapper.slice.max_z);
}

template <typename M>
void MapperNode::connectAll(const std::string& topics, std::uint32_t queue, const ros::TransportHints& hints,
                            std::vector<std::unique_ptr<Input<M>>>* inputs) {
  for (const std::string& topic : topicNames(topics)) {
    inputs->push_back(std::make_unique<Input<M>>());
    Input<M>* input = inputs->back().get();
    input->topic = nh_.resolveName(topic);
    {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      counters_.topics[input->topic];  // listed on /diagnostics from the start, at 0
    }
    connect(topic, queue, hints, input);
  }
}

template <typename M>
void MapperNode::connect(const std::string& topic, std::uint32_t queue, const ros::TransportHints& hints,
                         Input<M>* input) {
  input->subscriber.subscribe(nh_, topic, queue, hints);
  // Registered before the filter connects, so a message is recorded before the filter can answer.
  input->subscriber.registerCallback(boost::function<void(const ros::MessageEvent<M const>&)>(
      [this, input](const ros::MessageEvent<M const>& event) {
        const boost::shared_ptr<const M>& msg = event.getConstMessage();
        input->waiting.arrived(msg, ros::WallTime::now());
        // What never came is warned of once a second (publishDiagnostics), once its stream has
        // gone on past it: a gap that a late message fills is no loss.
        input->sequence.add(event.getPublisherName(), msg->header.seq);
        std::lock_guard<std::mutex> lock(counters_mutex_);
        TopicCounters& own = counters_.topics[input->topic];
        const std::uint64_t missed_before = own.missed, lost_before = own.lost;
        own.received++;
        own.missed = input->sequence.missed();  // (a late one is taken back)
        own.lost = input->sequence.settled();
        Kind<M>::received(counters_)++;
        Kind<M>::missed(counters_) += own.missed - missed_before;  // unsigned: wraps back as it must
        Kind<M>::lost(counters_) += own.lost - lost_before;
      }));
  // No tolerance: a message is handled as soon as its transform exists (a tolerance would hold
  // every one back until tf runs that far ahead of it).
  input->filter = std::make_unique<tf2_ros::MessageFilter<M>>(input->subscriber, tf_buffer_, options_.frame_id, queue, nh_);
  input->filter->registerCallback(boost::function<void(const boost::shared_ptr<const M>&)>(
      [this, input](const boost::shared_ptr<const M>& msg) {
        // The pose now, while tf has it: the message may be held back for order longer than tf keeps it.
        Eigen::Isometry3d pose;
        std::string why;
        if (!sensorPose(msg->header, &pose, &why)) {  // gone since the filter looked: not seen happen
          if (input->waiting.dropped(msg)) skip("no_transform", why);
          handleReady(input);
          return;
        }
        if (!input->waiting.delivered(msg, pose)) return;  // timed out (and counted) or taken over already
        handleReady(input);
        if (input->waiting.held() > 0) {  // this one: an earlier message's transform is still missing
          std::lock_guard<std::mutex> lock(counters_mutex_);
          counters_.scans_held_for_order++;
        }
      }));
  input->filter->registerFailureCallback(boost::function<void(const boost::shared_ptr<const M>&, tf2_ros::FilterFailureReason)>(
      [this, input](const boost::shared_ptr<const M>& msg, tf2_ros::FilterFailureReason reason) {
        // Pushed out of the filter's full queue, a message whose transform is there is taken over.
        handleReady(input);
        if (!input->waiting.dropped(msg)) return;  // counted when it timed out, or taken over
        handleReady(input);  // the ones it held back
        onTransformFailure(msg, reason);
        clearTfIfFromTheFuture(msg->header, reason);
      }));
}

void MapperNode::skip(const std::string& reason, const std::string& message) {
  bool log = false;
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    counters_.skipped[reason]++;
    log = skip_log_.shouldLog(reason, ros::WallTime::now().toSec());
  }
  const char* what = reason.rfind("cloud_", 0) == 0 ? "point cloud" : "scan";
  if (log) ROS_WARN("skipping %s (%s): %s", what, reason.c_str(), message.c_str());
}

bool MapperNode::stampedZero(const std_msgs::Header& header) {
  if (!header.stamp.isZero()) return false;
  // tf2 reads time 0 as "the latest transform": inserted, it would land at the newest pose.
  skip("zero_stamp", "stamped 0 (frame '" + header.frame_id + "'): its pose is unknown");
  return true;
}

void MapperNode::expireTick(const ros::WallTimerEvent&) {
  for (auto& input : scans_) expireWaiting(input.get());
  for (auto& input : clouds_) expireWaiting(input.get());
  // A message given up no longer holds back the ones that arrived after it.
  for (auto& input : scans_) handleReady(input.get());
  for (auto& input : clouds_) handleReady(input.get());
}

template <typename M>
bool MapperNode::transformThere(const boost::shared_ptr<const M>& msg) {
  return tf_buffer_.canTransform(options_.frame_id, msg->header.frame_id, msg->header.stamp);
}

template <typename M>
bool MapperNode::poseIfThere(const boost::shared_ptr<const M>& msg, Eigen::Isometry3d* pose) {
  return transformThere(msg) && sensorPose(msg->header, pose, nullptr);
}

template <typename M>
void MapperNode::handleReady(Input<M>* input) {
  std::size_t taken_over = 0;
  const auto ready = input->waiting.takeReady(
      [this](const boost::shared_ptr<const M>& msg, Eigen::Isometry3d* pose) { return poseIfThere(msg, pose); },
      &taken_over);
  if (taken_over > 0) {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    counters_.scans_taken_over += taken_over;
  }
  for (const auto& r : ready) insert(r.msg, r.pose, input->topic);
}

// Messages still waiting for their transform after ~transform_timeout are given up and counted
// (the tf filter would otherwise hold them until newer ones push them out).
template <typename M>
void MapperNode::expireWaiting(Input<M>* input) {
  const auto transform_there = [this](const boost::shared_ptr<const M>& msg) { return transformThere(msg); };
  const auto expired =
      input->waiting.expire(ros::WallTime::now(), ros::WallDuration(options_.transform_timeout), transform_there);
  const std::string what = Kind<M>::kName;
  for (const boost::shared_ptr<const M>& msg : expired) {
    const std::string& frame = msg->header.frame_id;
    std::string why;
    if (!tf_buffer_._frameExists(frame)) {
      skip("unknown_frame", what + " frame '" + frame + "' is not in tf (waited " +
                                std::to_string(options_.transform_timeout) + " s)");
    } else {
      tf_buffer_.canTransform(options_.frame_id, frame, msg->header.stamp, &why);
      skip("transform_timeout", "no transform " + options_.frame_id + " <- '" + frame + "' for a " + what +
                                    " within " + std::to_string(options_.transform_timeout) + " s: " + why);
    }
  }
}

template <typename M>
void MapperNode::onTransformFailure(const boost::shared_ptr<const M>& msg, tf2_ros::FilterFailureReason reason) {
  const char* why = reason == tf2_ros::filter_failure_reasons::OutTheBack ? "older than the tf buffer"
                    : reason == tf2_ros::filter_failure_reasons::EmptyFrameID ? "empty frame_id"
                                                                               : "no transform in time";
  skip("no_transform", std::string(why) + ": " + options_.frame_id + " <- '" + msg->header.frame_id + "' at " +
                           std::to_string(msg->header.stamp.toSec()));
}

// A current message "older than the tf buffer" means the buffer holds data from the future: the
// clock jumped back (a bag --loop) and tf2_ros's own check missed it (a late message from before
// the jump refills the buffer right after it clears it; seen in scripts/soak, where a whole loop
// was lost). Clearing keeps static transforms (tf2's static caches ignore clear()).
void MapperNode::clearTfIfFromTheFuture(const std_msgs::Header& header, tf2_ros::FilterFailureReason reason) {
  constexpr double kCurrent = 1.0;  // s
  if (reason != tf2_ros::filter_failure_reasons::OutTheBack || header.stamp + ros::Duration(kCurrent) <= ros::Time::now()) {
    return;
  }
  tf_buffer_.clear();
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    counters_.time_jumps_back++;
  }
  ROS_WARN("tf held data from after a current message (%.3f s): the clock jumped back unnoticed; tf buffer cleared",
           header.stamp.toSec());
}

bool MapperNode::sensorPose(const std_msgs::Header& header, Eigen::Isometry3d* pose, std::string* why) {
  const std::optional<Eigen::Isometry3d> found =
      lookupPose(tf_buffer_, options_.frame_id, header.frame_id, header.stamp, why);
  if (found) *pose = *found;
  return found.has_value();
}

std::optional<Eigen::Vector3d> MapperNode::groundAt(const ros::Time& stamp) {
  const FloorBase base = floorBaseOf(options_.floor_base_frame);
  std::string why;
  if (std::optional<Eigen::Vector3d> ground = groundPoint(tf_buffer_, options_.frame_id, base, stamp, &why)) {
    return ground;
  }
  // The frame's floor is then found from its points alone: nothing is lost.
  if (base.required) {
    ROS_WARN_THROTTLE(5.0, "no transform %s <- %s (floor_base_frame) for a point cloud: its floor is found from its "
                      "points alone: %s", options_.frame_id.c_str(), base.frame.c_str(), why.c_str());
  }
  return std::nullopt;
}

void MapperNode::checkTimeJump(const ros::Time& stamp) {
  constexpr double kTolerance = 1.0;  // s: messages from several sources may interleave a little
  bool jumped = false;
  double seconds = 0.0;
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    if (!last_stamp_.isZero() && stamp + ros::Duration(kTolerance) < last_stamp_) {
      jumped = true;
      seconds = (last_stamp_ - stamp).toSec();
      counters_.time_jumps_back++;
    }
    last_stamp_ = stamp;
  }
  // tf2_ros's TransformListener clears its buffer itself when /clock jumps back; this message
  // already passed the tf filter with a transform at its own stamp, so the map stays consistent.
  if (jumped) {
    ROS_WARN("time jumped back by %.3f s (a bag restarted with --loop, or /clock reset; tf2_ros clears its buffer "
             "on a /clock jump): mapping continues", seconds);
  }
}

template <typename M>
void MapperNode::insert(const boost::shared_ptr<const M>& msg, const Eigen::Isometry3d& pose, const std::string& topic) {
  if (stampedZero(msg->header)) return;
  checkTimeJump(msg->header.stamp);
  typename Kind<M>::Core core;
  const ScanRejection rejection = Kind<M>::toCore(msg, pose, &core);
  if (rejection.rejected()) {
    skip(rejection.key, rejection.message);
    return;
  }
  const ros::Time stamp = msg->header.stamp;
  if constexpr (std::is_same_v<M, sensor_msgs::PointCloud2>) {
    core.ground = groundAt(stamp);
    if (core.ground) {
      std::lock_guard<std::mutex> lock(counters_mutex_);
      counters_.floor_ground_points++;
    }
    // Converted and prepared on the pipeline's workers, frames in parallel, applied in arrival
    // order; this thread goes back to the scans (it waits only when frames pile up).
    cloud_pipeline_->submit(std::move(core),
                            [this, stamp, &topic](const CloudPipeline::Outcome& o) { inserted<M>(o, stamp, topic); });
  } else {
    CloudPipeline::Outcome outcome;
    const ros::WallTime start = ros::WallTime::now();
    const double cpu_start = threadCpuSeconds();
    outcome.result = session_.insert(core, &outcome.waited_ms);
    outcome.work_seconds = outcome.seconds = (ros::WallTime::now() - start).toSec();
    outcome.cpu_seconds = threadCpuSeconds() - cpu_start;
    inserted<M>(outcome, stamp, topic);
  }
}

template <typename M>
void MapperNode::inserted(const CloudPipeline::Outcome& outcome, const ros::Time& stamp, const std::string& topic) {
  const InsertResult& result = outcome.result;
  if (!result.ok()) {
    skip(Kind<M>::kInvalid, result.error);
    return;
  }
  publisher_.publishChange(session_, result.touched, stamp);
  if (result.readings.skipped() > 0) {
    // Single dropouts are normal for a lidar: counted, and only shown at debug level.
    ROS_DEBUG_THROTTLE(10.0, "%s readings: %s", Kind<M>::kName, result.readings.summary().c_str());
  }
  std::lock_guard<std::mutex> lock(counters_mutex_);
  Kind<M>::inserted(counters_)++;
  counters_.topics[topic].inserted++;
  Kind<M>::seconds(counters_) += outcome.work_seconds;
  Kind<M>::cpuSeconds(counters_) += outcome.cpu_seconds;
  counters_.last_insert_ms = 1000.0 * outcome.seconds;
  counters_.max_insert_wait_ms = std::max(counters_.max_insert_wait_ms, outcome.waited_ms);
}

void MapperNode::publishDiagnostics(const ros::WallTimerEvent&) {
  NodeCounters c;
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    c = counters_;
  }
  session_.withMapper([&c](const Mapper& mapper) {
    // Kept by the octree, read without a walk: counting the leaves walked the whole tree under the
    // map's lock, 1-3 ms (up to 8) on a Freiburg 079-sized map, while scans waited. No flush either.
    c.octree_nodes = mapper.flushedTree().size();
    c.unflushed_voxels = mapper.unflushedVoxels();
    c.known_cells = mapper.slice().knownCells();
    c.kept_scans = mapper.scanStore().scans().size();
    c.revisit_scans_not_kept = mapper.scanStore().skippedAsRevisit();
    const FloorStatus floor = mapper.floor().status();
    c.floor_source = floorSourceName(floor.source);
    c.floor_height = floor.height;
    c.floor_tilt = floor.tilt;
    c.floor_frames_found = floor.frames_found;
    c.floor_frames_without = floor.frames_without;
    c.floor_cells = floor.cells;
  });
  c.longest_service_lock_ms = session_.longestLockMs();
  c.longest_service_lock_cpu_ms = session_.longestLockCpuMs();
  c.waiting_for_tf = 0;  // this timer runs on the same queue as the scans
  for (const auto& input : scans_) c.waiting_for_tf += input->waiting.waiting();
  if (online_pass_) {
    const OnlinePassStats online = online_pass_->stats();
    c.online_passes = online.passes;
    c.online_pass_seconds = online.last_pass_seconds;
    c.optimized_map_age = online.last_result_age;
  }
  const std::string lost = lostSince(c, at_last_report_);
  if (!lost.empty()) ROS_WARN_THROTTLE(10.0, "%s", lost.c_str());
  diagnostics_pub_.publish(toDiagnostics(c, at_last_report_, ros::this_node::getName(), ros::Time::now()));
  at_last_report_ = c;
}

std::string MapperNode::summary() {
  NodeCounters c;
  {
    std::lock_guard<std::mutex> lock(counters_mutex_);
    c = counters_;
  }
  MapFigures map;
  session_.withMapper([&map](Mapper& mapper) {
    map.readings = mapper.stats().readings.summary();
    map.beams_outside_octree = mapper.stats().beams_outside_octree;
    if (mapper.stats().clouds_inserted) map.cloud_points = mapper.stats().cloud_points.summary();
    map.voxels = mapper.tree().getNumLeafNodes();
    map.known_cells = mapper.slice().knownCells();
  });
  return sessionSummary(c, map, (ros::WallTime::now() - started_).toSec());
}

// Runs after ros::spin() returned; roscpp has shut rosconsole down by then, so print directly.
void MapperNode::shutdown() {
  cloud_pipeline_.reset();  // applies the clouds still in it
  reconfigure_.reset();
  services_->stop();
  online_pass_.reset();  // waits for a running pass
  voxels_publisher_.reset();
  services_->saveOnShutdown();
  std::fprintf(stderr, "[mapper_node] session summary: %s\n", summary().c_str());
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
