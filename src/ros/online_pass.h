// The background global pass, wired to ROS: every ~online_optimize_period wall seconds, when the
// map changed since the last pass got its input, the node's `take_input` copies the kept scans
// and the slice (under the node's map lock) for the core OnlineOptimizer; each result goes out on
// ~optimized_map (latched), to `on_result` (the node makes it the best map, on `map`) and is what
// dynamic_map answers. Runs on its own callback queue and thread, so neither copying nor
// publishing a large grid waits between scans.
#pragma once

#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "octo_slice_mapper/online_optimizer.h"
#include "ros/own_thread_timer.h"

namespace octo_slice_mapper {
namespace ros_adapter {

struct OnlinePassStats {
  std::uint64_t passes = 0;
  double last_pass_seconds = 0.0;
  // How old the newest scan the published result explains was when it was published (s, ROS time).
  double last_result_age = 0.0;
};

class OnlinePass {
 public:
  // Returns the pass's input, or nothing when the map did not change since the last input.
  using InputFn = std::function<std::optional<OnlineOptimizerInput>()>;
  // Called with each result, before forget() can return: a result of a map reset since is never
  // passed on after the reset.
  using ResultFn = std::function<void(const nav_msgs::OccupancyGrid&)>;
  OnlinePass(ros::NodeHandle pnh, const GlobalOptimizerOptions& options, double resolution, double slice_min_z,
             std::string frame_id, double period, InputFn take_input, ResultFn on_result = {});

  // The newest published result (false before the first).
  bool latest(nav_msgs::OccupancyGrid* grid) const;
  // The map was reset or replaced: results of passes over the old one are not published.
  void forget();
  OnlinePassStats stats() const;

 private:
  void tick();

  OnlineOptimizer optimizer_;
  double slice_min_z_;
  std::string frame_id_;
  InputFn take_input_;
  ResultFn on_result_;
  ros::Publisher publisher_;
  mutable std::mutex mutex_;  // guards latest_ and stats_
  std::optional<nav_msgs::OccupancyGrid> latest_;
  std::uint64_t generation_ = 0;  // counts forget()s
  OnlinePassStats stats_;
  OwnThreadTimer timer_;  // last: ticks use all of the above
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
