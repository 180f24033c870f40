// carmen2bag: writes a CARMEN log as a rosbag (LaserScan, tf odom -> base_link -> laser, odom), so
// that replay.launch maps the Radish datasets through a real ROS session:
//
//   carmen2bag LOG[.gz] OUT.bag [--laser-z M] [--fixed-frame odom]
//   roslaunch octo_slice_mapper replay.launch bag:=OUT.bag save:=intel
#include <iostream>
#include <string>

#include "carmen_bag_writer.h"
#include "progress_bar.h"

int main(int argc, char** argv) {
  namespace osm = octo_slice_mapper;
  std::string log, bag;
  osm::CarmenLogOptions log_options;
  osm::tools::CarmenBagOptions bag_options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--laser-z" && i + 1 < argc) log_options.laser_z = std::stod(argv[++i]);
    else if (arg == "--fixed-frame" && i + 1 < argc) bag_options.fixed_frame = argv[++i];
    else if (arg[0] != '-' && log.empty()) log = arg;
    else if (arg[0] != '-' && bag.empty()) bag = arg;
    else {
      std::cerr << "usage: carmen2bag LOG[.gz] OUT.bag [--laser-z M] [--fixed-frame odom]\n";
      return 2;
    }
  }
  if (log.empty() || bag.empty()) {
    std::cerr << "usage: carmen2bag LOG[.gz] OUT.bag [--laser-z M] [--fixed-frame odom]\n";
    return 2;
  }
  osm::CarmenLogReader reader(log_options);
  std::string error;
  if (!reader.open(log, &error)) {
    std::cerr << "carmen2bag: " << error << "\n";
    return 1;
  }
  osm::tools::ProgressBar bar;
  osm::tools::CarmenBagReport report;
  const bool ok = osm::tools::writeCarmenBag(&reader, bag, bag_options, &report, &error,
                                             [&](double f) { bar.update("converting", f); });
  bar.finish();
  for (const osm::LogProblem& p : reader.problems()) std::cerr << "carmen2bag: " << log << ":" << p.line << ": " << p.message << "\n";
  if (!report.log_error.empty()) std::cerr << "carmen2bag: " << report.log_error << "; the bag holds the scans before it\n";
  if (!ok) {
    std::cerr << "carmen2bag: " << error << "\n";
    return 1;
  }
  std::cout << "carmen2bag: wrote " << bag << " (" << report.scans << " scans, " << report.bad_lines << " bad lines)\n";
  return 0;
}
