#include "ros/online_pass.h"

#include "ros/map_conversion.h"

namespace octo_slice_mapper {
namespace ros_adapter {

OnlinePass::OnlinePass(ros::NodeHandle pnh, const GlobalOptimizerOptions& options, double resolution,
                       double slice_min_z, std::string frame_id, double period, InputFn take_input,
                       ResultFn on_result)
    : optimizer_(options, resolution),
      slice_min_z_(slice_min_z),
      frame_id_(std::move(frame_id)),
      take_input_(std::move(take_input)),
      on_result_(std::move(on_result)),
      publisher_(pnh.advertise<nav_msgs::OccupancyGrid>("optimized_map", 1, true)),
      timer_(pnh, period, [this] { tick(); }) {}

void OnlinePass::tick() {
  std::uint64_t generation;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    generation = generation_;
  }
  if (std::optional<OnlineOptimizerResult> result = optimizer_.take()) {
    nav_msgs::OccupancyGrid grid;
    const ros::Time now = ros::Time::now();
    // Stamped with the newest scan the map explains (how fresh it is); map_load_time is when it
    // went out.
    toOccupancyGrid(result->shown, slice_min_z_, frame_id_, ros::Time(result->newest_stamp), &grid);
    grid.info.map_load_time = now;
    const double age = now.toSec() - result->newest_stamp;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (generation != generation_) return;  // the map was reset since: this result is of the old one
      latest_ = grid;
      stats_.passes++;
      stats_.last_pass_seconds = result->seconds;
      stats_.last_result_age = age;
      if (on_result_) on_result_(grid);
    }
    publisher_.publish(grid);
    ROS_DEBUG("online global pass: %d sweeps, %.2f s, its map %.2f s behind the newest scan when published",
              result->map.report.sweeps, result->seconds, age);
  }
  if (optimizer_.busy()) return;
  if (std::optional<OnlineOptimizerInput> input = take_input_()) optimizer_.submit(std::move(*input));
}

bool OnlinePass::latest(nav_msgs::OccupancyGrid* grid) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!latest_) return false;
  *grid = *latest_;
  return true;
}

void OnlinePass::forget() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++generation_;
  optimizer_.forget();
  latest_.reset();
}

OnlinePassStats OnlinePass::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
