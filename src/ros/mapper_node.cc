#include "ros/mapper_node.h"

#include <tf2_eigen/tf2_eigen.h>

#include <boost/bind/bind.hpp>
#include <cstdio>
#include <sstream>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/save_path.h"
#include "ros/laser_scan_conversion.h"
#include "ros/map_conversion.h"
#include "ros/point_cloud_conversion.h"

namespace octo_slice_mapper {
namespace ros_adapter {

namespace {

std::string describe(const OptimizeReport& r) {
  char text[256];
  std::snprintf(text, sizeof(text), "global pass: %d sweeps (%s), log-likelihood %.1f -> %.1f, %zu cells, %zu beams, %.2f s",
                r.sweeps, r.converged ? "converged" : "stopped at max_sweeps", r.initial_log_likelihood,
                r.final_log_likelihood, r.cells, r.beams, r.build_seconds + r.optimize_seconds);
  return text;
}

}  // namespace

MapperNode::MapperNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh),
      pnh_(pnh),
      options_(readNodeOptions(pnh)),
      mapper_(readMapperOptions(pnh)),
      tf_listener_(tf_buffer_),
      started_(ros::WallTime::now()) {
  if (!options_.map_file.empty()) {
    std::string error;
    if (mapper_.load(options_.map_file, &error)) {
      ROS_INFO("resumed map %s (%zu leaves)", options_.map_file.c_str(), mapper_.tree().getNumLeafNodes());
      const MapSetCheck set = checkMapSet(mapSetPrefixOf(options_.map_file));
      if (set.mixed()) {
        ROS_WARN("~map_file's set is mixed, a save was killed between renaming its files: %s. The map was read "
                 "from %s alone, which is whole.", set.describe().c_str(), options_.map_file.c_str());
      }
    } else {
      ROS_ERROR("could not load ~map_file: %s; starting with an empty map", error.c_str());
    }
  }
  // What saves killed mid-write left in maps_dir (each set's final names are whole; see README).
  if (const std::size_t stale = removeStaleTemporariesIn(options_.maps_dir)) {
    ROS_INFO("removed %zu temporary files a killed save had left in %s", stale, options_.maps_dir.c_str());
  }
  map_pub_ = nh_.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  metadata_pub_ = nh_.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  // What each scan changed, right after it is inserted (rviz's Map display reads map_updates).
  map_updates_pub_ = nh_.advertise<map_msgs::OccupancyGridUpdate>("map_updates", 100);
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("occupied_cells", 1, true);
  optimized_pub_ = pnh_.advertise<nav_msgs::OccupancyGrid>("optimized_map", 1, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 5);
  ros::NodeHandle services(pnh_);
  services.setCallbackQueue(&service_queue_);
  save_srv_ = services.advertiseService("save_map", &MapperNode::onSaveMap, this);
  reset_srv_ = services.advertiseService("reset", &MapperNode::onReset, this);
  optimize_srv_ = services.advertiseService("optimize", &MapperNode::onOptimize, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();
  // The slice on request, as gmapping and hector_mapping offer it. On the scans' queue, like the
  // map publisher: it must not wait behind a long save or global pass.
  get_map_srv_ = nh_.advertiseService("dynamic_map", &MapperNode::onGetMap, this);

  const uint32_t queue = static_cast<uint32_t>(std::max(1, options_.scan_queue_size));
  scan_sub_.subscribe(nh_, "scan", queue, ros::TransportHints().tcpNoDelay());
  // Registered before the filter connects, so a scan is recorded before the filter can answer.
  scan_sub_.registerCallback(boost::function<void(const sensor_msgs::LaserScan::ConstPtr&)>(
      [this](const sensor_msgs::LaserScan::ConstPtr& msg) {
        waiting_scans_.arrived(msg, ros::WallTime::now());
        std::lock_guard<std::mutex> lock(mutex_);
        counters_.scans_received++;
      }));
  // No tolerance: a scan is handled as soon as its transform exists (a tolerance would hold every
  // scan back until tf runs that far ahead of it).
  scan_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::LaserScan>>(scan_sub_, tf_buffer_,
                                                                                 options_.frame_id, queue, nh_);
  expire_timer_ = nh_.createWallTimer(ros::WallDuration(0.05), &MapperNode::expireWaitingScans, this);
  scan_filter_->registerCallback(boost::function<void(const sensor_msgs::LaserScan::ConstPtr&)>(
      [this](const sensor_msgs::LaserScan::ConstPtr& msg) {
        if (!waiting_scans_.delivered(msg)) return;  // timed out (and counted) or taken over already
        handleReadyScans();
        if (waiting_scans_.held() > 0) {  // this one: an earlier scan's transform is still missing
          std::lock_guard<std::mutex> lock(mutex_);
          counters_.scans_held_for_order++;
        }
      }));
  scan_filter_->registerFailureCallback(boost::bind(&MapperNode::onScanTransformFailure, this, boost::placeholders::_1, boost::placeholders::_2));

  cloud_sub_.subscribe(nh_, "cloud_in", 5);
  cloud_sub_.registerCallback(boost::function<void(const sensor_msgs::PointCloud2::ConstPtr&)>(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) {
        waiting_clouds_.arrived(msg, ros::WallTime::now());
        std::lock_guard<std::mutex> lock(mutex_);
        counters_.clouds_received++;
      }));
  cloud_filter_ = std::make_unique<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>>(cloud_sub_, tf_buffer_,
                                                                                    options_.frame_id, 5, nh_);
  cloud_filter_->registerCallback(boost::function<void(const sensor_msgs::PointCloud2::ConstPtr&)>(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) {
        if (waiting_clouds_.delivered(msg)) handleReadyClouds();
      }));
  cloud_filter_->registerFailureCallback(boost::function<void(const sensor_msgs::PointCloud2::ConstPtr&, tf2_ros::FilterFailureReason)>(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg, tf2_ros::FilterFailureReason reason) {
        if (waiting_clouds_.dropped(msg)) onTransformFailure(msg, reason);  // else counted at its timeout
        handleReadyClouds();
      }));

  publish_timer_ = nh_.createTimer(ros::Duration(1.0 / std::max(0.1, options_.publish_rate)), &MapperNode::publish, this);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), &MapperNode::publishDiagnostics, this);
  if (options_.online_optimize && mapper_.options().keep_scans) {
    online_pass_ = std::make_unique<OnlinePass>(pnh_, mapper_.options().optimizer, mapper_.options().resolution,
                                                mapper_.options().slice.min_z, options_.frame_id,
                                                options_.online_optimize_period, [this] { return onlinePassInput(); });
  }
  ROS_INFO("mapping in frame '%s' at %.3f m, slice z [%.2f, %.2f] m", options_.frame_id.c_str(),
           mapper_.options().resolution, mapper_.options().slice.min_z, mapper_.options().slice.max_z);
}

void MapperNode::skip(const std::string& reason, const std::string& message) {
  bool log = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.skipped[reason]++;
    // One throttle per reason: a flood of one kind must not hide the first of another.
    const ros::WallTime now = ros::WallTime::now();
    auto [last, first] = last_logged_skip_.emplace(reason, now);
    log = first || (now - last->second).toSec() >= 5.0;
    if (log) last->second = now;
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

void MapperNode::expireWaitingScans(const ros::WallTimerEvent&) {
  expireWaiting(&waiting_scans_, "scan");
  expireWaiting(&waiting_clouds_, "point cloud");
  // A message given up no longer holds back the ones that arrived after it.
  handleReadyScans();
  handleReadyClouds();
}

template <typename M>
bool MapperNode::transformThere(const boost::shared_ptr<const M>& msg) {
  return tf_buffer_.canTransform(options_.frame_id, msg->header.frame_id, msg->header.stamp);
}

void MapperNode::handleReadyScans() {
  std::size_t taken_over = 0;
  const auto ready = waiting_scans_.takeReady(
      [this](const sensor_msgs::LaserScan::ConstPtr& msg) { return transformThere(msg); }, &taken_over);
  if (taken_over > 0) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.scans_taken_over += taken_over;
  }
  for (const sensor_msgs::LaserScan::ConstPtr& msg : ready) insertScan(msg);
}

void MapperNode::handleReadyClouds() {
  const auto ready = waiting_clouds_.takeReady(
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { return transformThere(msg); });
  for (const sensor_msgs::PointCloud2::ConstPtr& msg : ready) insertCloud(msg);
}

// Messages still waiting for their transform after ~transform_timeout are given up and counted
// (the tf filter would otherwise hold them until newer ones push them out).
template <typename M>
void MapperNode::expireWaiting(PendingMessages<M>* waiting, const std::string& what) {
  const auto transform_there = [this](const boost::shared_ptr<const M>& msg) { return transformThere(msg); };
  const auto expired =
      waiting->expire(ros::WallTime::now(), ros::WallDuration(options_.transform_timeout), transform_there);
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

void MapperNode::onScanTransformFailure(const sensor_msgs::LaserScan::ConstPtr& msg,
                                        tf2_ros::FilterFailureReason reason) {
  if (!waiting_scans_.dropped(msg)) return;  // counted when it timed out
  handleReadyScans();  // the ones it held back
  onTransformFailure(msg, reason);
  // A current scan "older than the tf buffer" means the buffer holds data from the future: the
  // clock jumped back (a bag --loop) and tf2_ros's own check missed it (a late message from before
  // the jump refills the buffer right after it clears it; seen in scripts/soak, where a whole loop
  // was lost). Clearing keeps static transforms (tf2's static caches ignore clear()).
  constexpr double kCurrent = 1.0;  // s
  if (reason == tf2_ros::filter_failure_reasons::OutTheBack && msg->header.stamp + ros::Duration(kCurrent) > ros::Time::now()) {
    tf_buffer_.clear();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.time_jumps_back++;
    }
    ROS_WARN("tf held data from after a current scan (%.3f s): the clock jumped back unnoticed; tf buffer cleared",
             msg->header.stamp.toSec());
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

bool MapperNode::sensorPose(const std_msgs::Header& header, Eigen::Isometry3d* pose) {
  try {
    *pose = tf2::transformToEigen(tf_buffer_.lookupTransform(options_.frame_id, header.frame_id, header.stamp));
    return true;
  } catch (const tf2::TransformException& e) {
    skip("no_transform", e.what());
    return false;
  }
}

void MapperNode::checkTimeJump(const ros::Time& stamp) {
  constexpr double kTolerance = 1.0;  // s: scans from several sources may interleave a little
  bool jumped = false;
  double seconds = 0.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_scan_stamp_.isZero() && stamp + ros::Duration(kTolerance) < last_scan_stamp_) {
      jumped = true;
      seconds = (last_scan_stamp_ - stamp).toSec();
      counters_.time_jumps_back++;
    }
    last_scan_stamp_ = stamp;
  }
  // tf2_ros's TransformListener clears its buffer itself when /clock jumps back; this scan already
  // passed the tf filter with a transform at its own stamp, so the map stays consistent.
  if (jumped) {
    ROS_WARN("time jumped back by %.3f s (a bag restarted with --loop, or /clock reset; tf2_ros clears its buffer "
             "on a /clock jump): mapping continues", seconds);
  }
}

void MapperNode::insertScan(const sensor_msgs::LaserScan::ConstPtr& msg) {
  if (stampedZero(msg->header)) return;
  Eigen::Isometry3d pose;
  if (!sensorPose(msg->header, &pose)) return;
  checkTimeJump(msg->header.stamp);
  Scan scan;
  const ScanRejection rejection = toCoreScan(*msg, pose, &scan);
  if (rejection.rejected()) {
    skip(rejection.key, rejection.message);
    return;
  }
  const ros::WallTime start = ros::WallTime::now();
  InsertResult result;
  map_msgs::OccupancyGridUpdate update;
  bool send_update = false, send_full = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.max_insert_wait_ms = std::max(counters_.max_insert_wait_ms, 1000.0 * (ros::WallTime::now() - start).toSec());
    result = mapper_.insert(scan);
    if (result.ok() && !result.touched.empty()) {
      // The grid grew or moved: an update can't describe that, the whole map goes out first.
      send_full = mapper_.slice().geometry() != published_geometry_;
      send_update = !send_full &&
                    toOccupancyGridUpdate(mapper_.slice(), result.touched, options_.frame_id, msg->header.stamp, &update);
    }
  }
  if (!result.ok()) {
    skip("invalid_scan", result.error);
    return;
  }
  if (send_full) publishFullMap(msg->header.stamp, /*with_markers=*/false);
  if (send_update) map_updates_pub_.publish(update);
  if (result.readings.skipped() > 0) {
    // Single dropouts are normal for a lidar: counted, and only shown at debug level.
    ROS_DEBUG_THROTTLE(10.0, "scan readings: %s", result.readings.summary().c_str());
  }
  afterInsert(result, (ros::WallTime::now() - start).toSec(), /*from_scan=*/true);
}

void MapperNode::insertCloud(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  if (stampedZero(msg->header)) return;
  Eigen::Isometry3d pose;
  if (!sensorPose(msg->header, &pose)) return;
  // Checked before a single byte is read: a layout that declares more than the message holds
  // must not reach a converter that trusts it.
  const ScanRejection rejection = checkCloudLayout(*msg);
  if (rejection.rejected()) {
    skip(rejection.key, rejection.message);
    return;
  }
  std::vector<Eigen::Vector3f> points;
  cloudPointsInMap(*msg, pose.cast<float>(), &points);
  const ros::WallTime start = ros::WallTime::now();
  InsertResult result;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    result = mapper_.insertPoints(pose.translation(), points);
  }
  if (!result.ok()) {
    skip("invalid_cloud", result.error);
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.clouds_inserted++;
  }
  afterInsert(result, (ros::WallTime::now() - start).toSec(), /*from_scan=*/false);
}

void MapperNode::afterInsert(const InsertResult& result, double seconds, bool from_scan) {
  std::lock_guard<std::mutex> lock(mutex_);
  insert_seconds_ += seconds;
  if (from_scan) counters_.scans_inserted++;
  counters_.last_insert_ms = 1000.0 * seconds;
  if (result.voxels_updated > 0) {
    map_changed_ = true;
    map_version_++;
  }
}

void MapperNode::publish(const ros::TimerEvent&) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_changed_) return;
  }
  publishFullMap(ros::Time::now(), /*with_markers=*/true);
}

void MapperNode::publishFullMap(const ros::Time& stamp, bool with_markers) {
  nav_msgs::OccupancyGrid grid;
  visualization_msgs::MarkerArray markers;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map_changed_ = false;
    published_geometry_ = mapper_.slice().geometry();
    toOccupancyGrid(mapper_.slice(), options_.frame_id, stamp, &grid);
    if (with_markers && options_.publish_markers && markers_pub_.getNumSubscribers() > 0) {
      markers = occupiedVoxelMarkers(mapper_.tree(), options_.frame_id, stamp);
    }
  }
  map_pub_.publish(grid);
  metadata_pub_.publish(grid.info);
  if (!markers.markers.empty()) markers_pub_.publish(markers);
}

void MapperNode::publishDiagnostics(const ros::TimerEvent&) {
  diagnostic_msgs::DiagnosticArray array;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.voxels = mapper_.flushedTree().getNumLeafNodes();  // a flush here would stall the scans
    counters_.known_cells = mapper_.slice().knownCells();
    counters_.kept_scans = mapper_.scanStore().scans().size();
    counters_.revisit_scans_not_kept = mapper_.scanStore().skippedAsRevisit();
    counters_.waiting_for_tf = waiting_scans_.waiting();  // this timer runs on the same queue as the scans
    if (online_pass_) {
      const OnlinePassStats online = online_pass_->stats();
      counters_.online_passes = online.passes;
      counters_.online_pass_seconds = online.last_pass_seconds;
      counters_.optimized_map_age = online.last_result_age;
    }
    array = toDiagnostics(counters_, skipped_at_last_report_, ros::this_node::getName(), ros::Time::now());
    skipped_at_last_report_ = counters_.skippedTotal();
  }
  diagnostics_pub_.publish(array);
}

bool MapperNode::onSaveMap(SaveMap::Request& req, SaveMap::Response& res) {
  std::string prefix, error;
  if (!resolveSavePrefix(options_.maps_dir, req.prefix, options_.allow_any_path, &prefix, &error)) {
    res.success = false;
    res.message = error;
    ROS_WARN("~save_map: %s", error.c_str());
    return true;
  }
  std::lock_guard<std::mutex> one_at_a_time(service_mutex_);
  MapSnapshot snapshot;
  std::uint64_t saved_version = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime held = ros::WallTime::now();
    snapshot = mapper_.snapshot(/*with_scans=*/options_.optimize_on_save);
    saved_version = map_version_;
    noteServiceLock(held);
  }
  OctreeLoan loan(&mapper_, &mutex_);  // scans keep going into the insertion cache meanwhile
  res.success = saveMapSet(*snapshot.tree, snapshot.slice, prefix, &res.files, &error);
  std::string global_pass;
  std::unique_ptr<OptimizedMap> optimized;
  if (res.success && options_.optimize_on_save && snapshot.scans.empty()) {
    global_pass = "; global pass skipped: no kept scans (~keep_scans is false, or nothing inserted)";
  } else if (res.success && options_.optimize_on_save) {
    optimized = std::make_unique<OptimizedMap>(optimizeSnapshot(snapshot, options_.optimize_warm_start));
    global_pass = "; " + describe(optimized->report);
    res.success = saveOptimizedSet(*snapshot.tree, snapshot.band_lo, snapshot.band_hi, optimized->grid,
                                   snapshot.slice, prefix, &res.files, &error);
  }
  loan.end();
  if (optimized) applyOptimizedToMap(optimized->grid);
  if (res.success) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_saved_prefix_ = prefix;
    last_saved_version_ = saved_version;
  }
  if (res.success) {
    res.message = "saved";
    for (const std::string& f : res.files) res.message += " " + f;
    res.message += global_pass;
    ROS_INFO("~save_map: %s", res.message.c_str());
  } else {
    res.message = error;
    ROS_ERROR("~save_map: %s", res.message.c_str());
  }
  return true;
}

MapperNode::OctreeLoan::~OctreeLoan() { end(); }

void MapperNode::OctreeLoan::end() {
  if (!mapper_) return;
  std::lock_guard<std::mutex> lock(*mutex_);
  mapper_->endSnapshot();
  mapper_ = nullptr;
}

void MapperNode::noteServiceLock(const ros::WallTime& since) {
  counters_.longest_service_lock_ms =
      std::max(counters_.longest_service_lock_ms, 1000.0 * (ros::WallTime::now() - since).toSec());
}

OptimizedMap MapperNode::optimizeSnapshot(const MapSnapshot& snapshot, bool warm_start) {
  ROS_INFO("global pass over %zu scans (start: %s)", snapshot.scans.size(), warm_start ? "incremental map" : "all free");
  const OptimizedMap optimized = optimizeScans(
      snapshot.scans, mapper_.options().optimizer, mapper_.options().resolution, warm_start ? &snapshot.slice : nullptr,
      [](const std::string& stage, double fraction) { ROS_INFO_THROTTLE(2.0, "global pass: %s %.0f %%", stage.c_str(), 100.0 * fraction); });
  ROS_INFO("%s", describe(optimized.report).c_str());
  nav_msgs::OccupancyGrid grid;
  toOccupancyGrid(optimized.grid, mapper_.options().slice.min_z, options_.frame_id, ros::Time::now(), &grid);
  if (ros::ok()) optimized_pub_.publish(grid);
  return optimized;
}

void MapperNode::applyOptimizedToMap(const GridImage& grid) {
  if (!options_.write_optimized_into_map) return;
  // In strips of rows, each under the lock on its own, so that scans are inserted in between.
  const int rows = std::max(1, 4096 / std::max(1, grid.width));
  for (int j0 = 0; j0 < grid.height; j0 += rows) {
    GridImage strip;  // not a copy of `grid`: that would copy all its cells once per strip
    strip.width = grid.width;
    strip.resolution = grid.resolution;
    strip.origin_x = grid.origin_x;
    strip.height = std::min(rows, grid.height - j0);
    strip.origin_y = grid.origin_y + j0 * grid.resolution;
    strip.cells.assign(grid.cells.begin() + std::size_t(j0) * grid.width,
                       grid.cells.begin() + std::size_t(j0 + strip.height) * grid.width);
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime held = ros::WallTime::now();
    mapper_.applyOptimized(strip);
    map_changed_ = true;
    noteServiceLock(held);
  }
}

bool MapperNode::onOptimize(Optimize::Request& req, Optimize::Response& res) {
  std::lock_guard<std::mutex> one_at_a_time(service_mutex_);
  MapSnapshot snapshot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime held = ros::WallTime::now();
    // The scans and the slice only: the octree (and flushing the insertion cache into it under
    // the lock) is not needed for the global pass.
    snapshot = mapper_.optimizationInput();
    noteServiceLock(held);
  }
  if (snapshot.scans.empty()) {
    res.success = false;
    res.message = "no scans kept (none inserted yet, or ~keep_scans is false)";
    return true;
  }
  const OptimizedMap optimized = optimizeSnapshot(snapshot, req.warm_start);
  applyOptimizedToMap(optimized.grid);
  if (options_.write_optimized_into_map) {
    std::lock_guard<std::mutex> lock(mutex_);
    map_version_++;
  }
  const OptimizeReport& r = optimized.report;
  res.success = true;
  res.initial_log_likelihood = r.initial_log_likelihood;
  res.final_log_likelihood = r.final_log_likelihood;
  res.flips_per_sweep.assign(r.flips_per_sweep.begin(), r.flips_per_sweep.end());
  res.sweeps = static_cast<std::uint32_t>(r.sweeps);
  res.converged = r.converged;
  res.cells = static_cast<std::uint32_t>(r.cells);
  res.beams = static_cast<std::uint32_t>(r.beams);
  res.seconds = r.build_seconds + r.optimize_seconds;
  res.message = r.converged ? "converged: no single flip improves the map" : "stopped after ~max_sweeps sweeps";
  return true;
}

bool MapperNode::onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  std::lock_guard<std::mutex> one_at_a_time(service_mutex_);
  std::lock_guard<std::mutex> lock(mutex_);
  mapper_.reset();
  map_changed_ = true;
  map_version_++;
  if (online_pass_) online_pass_->forget();
  ROS_INFO("map reset");
  return true;
}

std::optional<OnlineOptimizerInput> MapperNode::onlinePassInput() {
  const ros::WallTime since = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (map_version_ == online_input_version_ || mapper_.scanStore().scans().empty()) return std::nullopt;
  online_input_version_ = map_version_;
  MapSnapshot copy = mapper_.optimizationInput();
  noteServiceLock(since);
  return OnlineOptimizerInput{std::move(copy.scans), std::move(copy.slice), map_version_, last_scan_stamp_.toSec()};
}

bool MapperNode::onGetMap(nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& res) {
  // The best map there is: the background pass's newest result, else the slice.
  if (online_pass_ && online_pass_->latest(&res.map)) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  toOccupancyGrid(mapper_.slice(), options_.frame_id, ros::Time::now(), &res.map);
  return true;
}

std::string MapperNode::summary() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const MapperStats& s = mapper_.stats();
  std::ostringstream out;
  // The session's count, as /diagnostics has it (the mapper's starts again at a reset).
  out << "scans_inserted=" << counters_.scans_inserted << " scans_skipped=" << counters_.skippedTotal()
      << " time_jumps_back=" << counters_.time_jumps_back
      << " scans_held_for_order=" << counters_.scans_held_for_order << " scans_taken_over=" << counters_.scans_taken_over;
  for (const auto& kv : counters_.skipped) out << " skipped_" << kv.first << '=' << kv.second;
  out << " readings: " << s.readings.summary() << " voxels=" << mapper_.tree().getNumLeafNodes()
      << " known_cells=" << mapper_.slice().knownCells() << " insert_ms_per_scan="
      << (counters_.scans_inserted ? 1000.0 * insert_seconds_ / counters_.scans_inserted : 0.0)
      << " wall_s=" << (ros::WallTime::now() - started_).toSec();
  return out.str();
}

bool MapperNode::savedAlready(const std::string& requested_prefix) const {
  std::string prefix, error;
  if (!resolveSavePrefix(options_.maps_dir, requested_prefix, options_.allow_any_path, &prefix, &error)) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  return prefix == last_saved_prefix_ && map_version_ == last_saved_version_;
}

// Runs after ros::spin() returned; roscpp has shut rosconsole down by then, so print directly.
void MapperNode::shutdown() {
  online_pass_.reset();  // waits for a running pass
  service_spinner_->stop();
  if (!options_.save_on_shutdown.empty() && savedAlready(options_.save_on_shutdown)) {
    std::fprintf(stderr, "[mapper_node] save on shutdown: skipped: the map is unchanged since it was saved to %s\n",
                 last_saved_prefix_.c_str());
  } else if (!options_.save_on_shutdown.empty()) {
    SaveMap::Request req;
    SaveMap::Response res;
    req.prefix = options_.save_on_shutdown;
    onSaveMap(req, res);
    std::fprintf(stderr, "[mapper_node] save on shutdown: %s: %s\n", res.success ? "ok" : "FAILED", res.message.c_str());
  }
  std::fprintf(stderr, "[mapper_node] session summary: %s\n", summary().c_str());
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
