#include "ros/mapper_services.h"

#include <cstdio>

#include "core/internal/save_path.h"
#include "ros/map_conversion.h"

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

void logProgress(const std::string& stage, double fraction) {
  ROS_INFO_THROTTLE(2.0, "global pass: %s %.0f %%", stage.c_str(), 100.0 * fraction);
}

}  // namespace

MapperServices::MapperServices(ros::NodeHandle nh, ros::NodeHandle pnh, const NodeOptions& options,
                               MappingSession* session, MapPublisher* publisher, OnlinePass* online)
    : options_(options), session_(session), publisher_(publisher), online_(online) {
  ros::NodeHandle services(pnh);
  services.setCallbackQueue(&queue_);
  save_srv_ = services.advertiseService("save_map", &MapperServices::onSaveMap, this);
  reset_srv_ = services.advertiseService("reset", &MapperServices::onReset, this);
  optimize_srv_ = services.advertiseService("optimize", &MapperServices::onOptimize, this);
  clear_box_srv_ = services.advertiseService("clear_box", &MapperServices::onClearBox, this);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
  // The map on request, as gmapping and hector_mapping offer it.
  get_map_srv_ = nh.advertiseService("dynamic_map", &MapperServices::onGetMap, this);
}

void MapperServices::stop() {
  spinner_->stop();
  online_ = nullptr;  // the node destroys it next
}

bool MapperServices::onSaveMap(SaveMap::Request& req, SaveMap::Response& res) {
  std::string prefix, error;
  if (!resolveSavePrefix(options_.maps_dir, req.prefix, options_.allow_any_path, &prefix, &error)) {
    res.success = false;
    res.message = error;
    ROS_WARN("~save_map: %s", error.c_str());
    return true;
  }
  const bool with_pass = session_->options().optimize_on_save;
  if (with_pass) ROS_INFO("~save_map: with the global pass");
  const SaveOutcome saved = session_->save(prefix, with_pass, logProgress);
  if (saved.optimized) {
    publisher_->publishOptimized(saved.optimized->grid, session_->mapperOptions().slice.min_z, online_ != nullptr);
  }
  res.success = saved.ok;
  res.files = saved.files;
  if (saved.ok) {
    res.message = "saved";
    for (const std::string& f : res.files) res.message += " " + f;
    if (saved.optimized) res.message += "; " + describe(saved.optimized->report);
    if (!saved.note.empty()) res.message += "; " + saved.note;
    ROS_INFO("~save_map: %s", res.message.c_str());
  } else {
    res.message = saved.error;
    ROS_ERROR("~save_map: %s", res.message.c_str());
  }
  return true;
}

bool MapperServices::onOptimize(Optimize::Request& req, Optimize::Response& res) {
  ROS_INFO("global pass over the kept scans (start: %s)", req.warm_start ? "incremental map" : "all free");
  const std::optional<OptimizedMap> optimized = session_->optimize(req.warm_start, logProgress);
  if (!optimized) {
    res.success = false;
    res.message = "no scans kept (none inserted yet, or ~keep_scans is false)";
    return true;
  }
  publisher_->publishOptimized(optimized->grid, session_->mapperOptions().slice.min_z, online_ != nullptr);
  const OptimizeReport& r = optimized->report;
  ROS_INFO("%s", describe(r).c_str());
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

bool MapperServices::onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  session_->reset();
  if (online_) online_->forget();
  publisher_->forgetBest(*session_, ros::Time::now());
  ROS_INFO("map reset");
  return true;
}

bool MapperServices::onClearBox(ClearBox::Request& req, ClearBox::Response& res) {
  const Eigen::Vector3d lo(req.min[0], req.min[1], req.min[2]), hi(req.max[0], req.max[1], req.max[2]);
  if (!lo.allFinite() || !hi.allFinite()) {
    res.success = false;
    res.message = "the box's corners must be finite";
    return true;
  }
  Mapper::Cleared cleared;
  std::string error;
  res.success = session_->clearBox(lo, hi, &cleared, &error);
  if (!res.success) {
    res.message = error;
    ROS_WARN("~clear_box: %s", error.c_str());
    return true;
  }
  if (online_) online_->forget();  // its last result still holds the box
  publisher_->forgetBest(*session_, ros::Time::now());
  res.voxels_cleared = static_cast<std::uint32_t>(cleared.voxels);
  res.scans_dropped = static_cast<std::uint32_t>(cleared.scans);
  res.message = "cleared " + std::to_string(cleared.voxels) + " voxels; dropped " + std::to_string(cleared.scans) +
                " kept scans whose beams crossed the box";
  ROS_INFO("~clear_box [%.2f %.2f %.2f] - [%.2f %.2f %.2f]: %s", lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z(),
           res.message.c_str());
  return true;
}

bool MapperServices::onGetMap(nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& res) {
  // The best map there is: the background pass's newest result, else the slice.
  if (online_ && online_->latest(&res.map)) return true;
  session_->withMapper(
      [&](const Mapper& mapper) { toOccupancyGrid(mapper.slice(), options_.frame_id, ros::Time::now(), &res.map); });
  return true;
}

void MapperServices::saveOnShutdown() {
  if (options_.save_on_shutdown.empty()) return;
  std::string prefix, error;
  const bool resolved =
      resolveSavePrefix(options_.maps_dir, options_.save_on_shutdown, options_.allow_any_path, &prefix, &error);
  if (resolved && session_->savedAlready(prefix)) {
    std::fprintf(stderr, "[mapper_node] save on shutdown: skipped: the map is unchanged since it was saved to %s\n",
                 prefix.c_str());
    return;
  }
  SaveMap::Request req;
  SaveMap::Response res;
  req.prefix = options_.save_on_shutdown;
  onSaveMap(req, res);
  std::fprintf(stderr, "[mapper_node] save on shutdown: %s: %s\n", res.success ? "ok" : "FAILED", res.message.c_str());
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
