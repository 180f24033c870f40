#include "ros/live_reconfigure.h"

#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>

#include "octo_slice_mapper/option_table.h"

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

namespace {

// Each tunable option: its field in the generated config; its field in MapperOptions is the
// option table's of the same name (option_table.h), so that no accessor is written twice.
struct Tunable {
  const char* name;
  double MapperConfig::*config;
};

const Tunable kTunables[] = {
    {"p_free", &MapperConfig::p_free},
    {"p_occupied", &MapperConfig::p_occupied},
    {"sigma_base", &MapperConfig::sigma_base},
    {"sigma_per_meter", &MapperConfig::sigma_per_meter},
    {"sigma_angle_gain", &MapperConfig::sigma_angle_gain},
    {"cone_taper_fraction", &MapperConfig::cone_taper_fraction},
    {"beam_opening_angle", &MapperConfig::beam_opening_angle},
    {"no_return_clear_distance", &MapperConfig::no_return_clear_distance},
    {"slice_min_z", &MapperConfig::slice_min_z},
    {"slice_max_z", &MapperConfig::slice_max_z},
    {"forward_z_hit", &MapperConfig::forward_z_hit},
    {"forward_z_rand", &MapperConfig::forward_z_rand},
    {"forward_z_miss", &MapperConfig::forward_z_miss},
    {"forward_sigma_base", &MapperConfig::forward_sigma_base},
    {"forward_sigma_per_meter", &MapperConfig::forward_sigma_per_meter},
};

// The option table's field `name` in `options` (every tunable is a double there; checked by
// parameter_table_test against cfg/Mapper.cfg).
double& optionField(MapperOptions& options, const char* name) {
  for (const OptionSpec<MapperOptions>& spec : mapperOptionTable()) {
    if (std::strcmp(spec.name, name) == 0) return *std::get<double*>(spec.field(options));
  }
  throw std::logic_error(std::string("live_reconfigure: no option ") + name);
}

}  // namespace

void LiveReconfigure::onConfig(MapperConfig& config, std::uint32_t) {
  if (config.publish_rate != publish_rate_) {
    if (publish_rate_ >= 0.0) ROS_INFO("reconfigure: publish_rate %g -> %g Hz", publish_rate_, config.publish_rate);
    publish_rate_ = config.publish_rate;
    set_publish_rate_(config.publish_rate);
  }
  MapperOptions now = session_->mapperOptions();
  MapperOptions wanted = now;
  std::ostringstream changed;  // for the log; nothing to do when nothing changed (the server's first call)
  for (const Tunable& t : kTunables) {
    const double before = optionField(now, t.name), after = config.*t.config;
    optionField(wanted, t.name) = after;
    if (before != after) changed << ' ' << t.name << ' ' << before << " -> " << after;
  }
  if (changed.str().empty()) return;
  std::string error;
  if (!session_->reconfigure(wanted, &error)) {
    ROS_WARN("reconfigure refused (%s):%s; the model stays as it was", error.c_str(), changed.str().c_str());
    // The server keeps (and shows rqt) what this returns: the values in force, not the refused ones.
    for (const Tunable& t : kTunables) config.*t.config = optionField(now, t.name);
    return;
  }
  ROS_INFO("reconfigure:%s (for the following scans; the slice is rebuilt for the band)", changed.str().c_str());
  if (on_change_) on_change_();
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
