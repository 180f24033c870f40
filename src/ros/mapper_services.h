// The node's services: ~save_map, ~reset, ~optimize and ~clear_box on a callback queue and thread of their
// own (a save or a global pass takes seconds; scans go on meanwhile, see MappingSession), and
// dynamic_map on the scans' queue, between scans, so it never waits behind them.
#pragma once

#include <nav_msgs/GetMap.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Empty.h>

#include <memory>
#include <string>

#include "octo_slice_mapper/ClearBox.h"
#include "octo_slice_mapper/Optimize.h"
#include "octo_slice_mapper/SaveMap.h"
#include "octo_slice_mapper/mapping_session.h"
#include "ros/map_publisher.h"
#include "ros/node_parameters.h"
#include "ros/online_pass.h"

namespace octo_slice_mapper {
namespace ros_adapter {

class MapperServices {
 public:
  // `online` may be null (no background pass).
  MapperServices(ros::NodeHandle nh, ros::NodeHandle pnh, const NodeOptions& options, MappingSession* session,
                 MapPublisher* publisher, OnlinePass* online);
  // Stops the services' thread (before the node shuts down).
  void stop();
  // Writes ~save_on_shutdown unless the last save wrote that prefix and nothing changed since;
  // prints what it did (rosconsole is gone by then).
  void saveOnShutdown();

 private:
  bool onSaveMap(SaveMap::Request& req, SaveMap::Response& res);
  bool onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool onOptimize(Optimize::Request& req, Optimize::Response& res);
  bool onClearBox(ClearBox::Request& req, ClearBox::Response& res);
  bool onGetMap(nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& res);

  const NodeOptions& options_;
  MappingSession* session_;
  MapPublisher* publisher_;
  OnlinePass* online_;
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::ServiceServer save_srv_, reset_srv_, optimize_srv_, clear_box_srv_, get_map_srv_;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
