#include "ros/live_reconfigure.h"

#include <sstream>

namespace octo_slice_mapper {
namespace ros_adapter {

LiveReconfigure::LiveReconfigure(ros::NodeHandle pnh, MappingSession* session,
                                 std::function<void(double)> set_publish_rate, std::function<void()> on_change)
    : session_(session),
      set_publish_rate_(std::move(set_publish_rate)),
      on_change_(std::move(on_change)),
      nh_(pnh) {
  nh_.setCallbackQueue(&queue_);
  server_ = std::make_unique<dynamic_reconfigure::Server<MapperConfig>>(nh_);
  server_->setCallback([this](MapperConfig& config, std::uint32_t level) { onConfig(config, level); });
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

LiveReconfigure::~LiveReconfigure() { spinner_->stop(); }

void LiveReconfigure::onConfig(MapperConfig& config, std::uint32_t) {
  if (config.publish_rate != publish_rate_) {
    if (publish_rate_ >= 0.0) ROS_INFO("reconfigure: publish_rate %g -> %g Hz", publish_rate_, config.publish_rate);
    publish_rate_ = config.publish_rate;
    set_publish_rate_(config.publish_rate);
  }
  const MapperOptions now = session_->withMapper([](const Mapper& m) { return m.options(); });
  MapperOptions wanted = now;
  InverseSensorModelOptions& m = wanted.insert.model;
  m.p_free = config.p_free;
  m.p_occupied = config.p_occupied;
  m.sigma_base = config.sigma_base;
  m.sigma_per_meter = config.sigma_per_meter;
  m.sigma_angle_gain = config.sigma_angle_gain;
  m.cone_taper_fraction = config.cone_taper_fraction;
  m.beam_opening_angle = config.beam_opening_angle;
  m.no_return_clear_distance = config.no_return_clear_distance;
  wanted.slice.min_z = config.slice_min_z;
  wanted.slice.max_z = config.slice_max_z;
  ForwardSensorModelOptions& f = wanted.optimizer.model;
  f.z_hit = config.forward_z_hit;
  f.z_rand = config.forward_z_rand;
  f.z_miss = config.forward_z_miss;
  f.sigma_base = config.forward_sigma_base;
  f.sigma_per_meter = config.forward_sigma_per_meter;
  // What changed, for the log (and nothing to do when nothing did: the server's first call).
  std::ostringstream changed;
  auto note = [&changed](const char* name, double before, double after) {
    if (before != after) changed << ' ' << name << ' ' << before << " -> " << after;
  };
  const InverseSensorModelOptions& o = now.insert.model;
  note("p_free", o.p_free, m.p_free);
  note("p_occupied", o.p_occupied, m.p_occupied);
  note("sigma_base", o.sigma_base, m.sigma_base);
  note("sigma_per_meter", o.sigma_per_meter, m.sigma_per_meter);
  note("sigma_angle_gain", o.sigma_angle_gain, m.sigma_angle_gain);
  note("cone_taper_fraction", o.cone_taper_fraction, m.cone_taper_fraction);
  note("beam_opening_angle", o.beam_opening_angle, m.beam_opening_angle);
  note("no_return_clear_distance", o.no_return_clear_distance, m.no_return_clear_distance);
  note("slice_min_z", now.slice.min_z, wanted.slice.min_z);
  note("slice_max_z", now.slice.max_z, wanted.slice.max_z);
  const ForwardSensorModelOptions& g = now.optimizer.model;
  note("forward_z_hit", g.z_hit, f.z_hit);
  note("forward_z_rand", g.z_rand, f.z_rand);
  note("forward_z_miss", g.z_miss, f.z_miss);
  note("forward_sigma_base", g.sigma_base, f.sigma_base);
  note("forward_sigma_per_meter", g.sigma_per_meter, f.sigma_per_meter);
  if (changed.str().empty()) return;
  std::string error;
  if (!session_->reconfigure(wanted, &error)) {
    ROS_WARN("reconfigure refused (%s):%s; the model stays as it was", error.c_str(), changed.str().c_str());
    // The server keeps (and shows rqt) what this returns: the values in force, not the refused ones.
    config.p_free = o.p_free;
    config.p_occupied = o.p_occupied;
    config.sigma_base = o.sigma_base;
    config.sigma_per_meter = o.sigma_per_meter;
    config.sigma_angle_gain = o.sigma_angle_gain;
    config.cone_taper_fraction = o.cone_taper_fraction;
    config.beam_opening_angle = o.beam_opening_angle;
    config.no_return_clear_distance = o.no_return_clear_distance;
    config.slice_min_z = now.slice.min_z;
    config.slice_max_z = now.slice.max_z;
    config.forward_z_hit = g.z_hit;
    config.forward_z_rand = g.z_rand;
    config.forward_z_miss = g.z_miss;
    config.forward_sigma_base = g.sigma_base;
    config.forward_sigma_per_meter = g.sigma_per_meter;
    return;
  }
  ROS_INFO("reconfigure:%s (for the following scans; the slice is rebuilt for the band)", changed.str().c_str());
  if (on_change_) on_change_();
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
