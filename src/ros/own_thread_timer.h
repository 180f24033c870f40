// A wall-clock timer whose callbacks run on a thread of their own (their own callback queue and
// spinner): periodic work that takes long (the background global pass, walking the octree) never
// waits behind the node's scans, nor do they wait behind it.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <algorithm>
#include <functional>
#include <utility>

namespace octo_slice_mapper {
namespace ros_adapter {

class OwnThreadTimer {
 public:
  // `tick` every `period` wall seconds (at least 0.05), from now on. Declare the timer after
  // everything `tick` uses: it is stopped first, and a running tick finished, when destroyed.
  OwnThreadTimer(const ros::NodeHandle& nh, double period, std::function<void()> tick) {
    ros::NodeHandle own(nh);
    own.setCallbackQueue(&queue_);
    timer_ = own.createWallTimer(ros::WallDuration(std::max(0.05, period)),
                                 [tick = std::move(tick)](const ros::WallTimerEvent&) { tick(); });
    spinner_.start();
  }
  ~OwnThreadTimer() {
    timer_.stop();
    spinner_.stop();
  }
  OwnThreadTimer(const OwnThreadTimer&) = delete;
  OwnThreadTimer& operator=(const OwnThreadTimer&) = delete;

 private:
  ros::CallbackQueue queue_;
  ros::AsyncSpinner spinner_{1, &queue_};
  ros::WallTimer timer_;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
