// dynamic_reconfigure for a live session: the inverse model, the slice band, the
// forward model and the publish rate (cfg/Mapper.cfg), so that rqt_reconfigure can tune them.
// A change goes to the MappingSession for the following scans and is logged.
#pragma once

#include <dynamic_reconfigure/server.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <functional>
#include <memory>

#include "octo_slice_mapper/MapperConfig.h"
#include "octo_slice_mapper/mapping_session.h"

namespace octo_slice_mapper {
namespace ros_adapter {

class LiveReconfigure {
 public:
  // `set_publish_rate` gets the new rate (Hz); `on_change` runs after the session took new options.
  // Requests are handled on a thread of their own: a change waits for a running save.
  LiveReconfigure(ros::NodeHandle pnh, MappingSession* session, std::function<void(double)> set_publish_rate,
                  std::function<void()> on_change);

 private:
  void onConfig(MapperConfig& config, std::uint32_t level);

  MappingSession* session_;
  std::function<void(double)> set_publish_rate_;
  std::function<void()> on_change_;
  double publish_rate_ = -1.0;
  ros::CallbackQueue queue_;
  ros::NodeHandle nh_;  // pnh on queue_
  std::unique_ptr<dynamic_reconfigure::Server<MapperConfig>> server_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;

 public:
  ~LiveReconfigure();
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
