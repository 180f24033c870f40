// bench_map_quality: how well each map predicts scans it never saw, on the shared CARMEN logs and
// the simulator. Every 10th scan from index 5 is held out; the rest build
//   - default: the map a user gets (/map, PREFIX.*): the global pass from the incremental map;
//   - incremental: the slice (~incremental_map, PREFIX_incremental.*);
//   - optimized_cold: the global pass from all-free (the lab's start), for comparison;
//   - octomap_server's method and a dense hit/miss grid (bench/peer_maps.h).
// Each map is judged as exported: the map_server reading of its .pgm (trinaryOf), every held-out
// return cast through it to the first occupied cell (scoreHeldOut, the rules of
// shared/tools/map_judge). With --out DIR the maps are also written as DIR/<data>_<map>.{pgm,yaml},
// so that the shared judge can check the figures.
// Data: the four shared logs (intel, fr079, acapulco, campus; $OSM_DATA_DIR); the simulator's
// office tour, made in-process, as simulated (sim_office: walls on cell boundaries), moved by half
// a cell (sim_office_half_cell), that with a corrected log's pose errors (sim_office_pose_errors;
// 2 cm and 0.5 deg, --pose-errors), and as a real robot records it (sim_real_robot: dead-reckoned
// odometry, ~1 deg of tilt, a yawed mount, REP 117). --bag FILE judges a bag's scans instead
// (topic "scan", placed with the bag's tf in frame "odom").
//
//   bench_map_quality [--data DIR] [--only NAME[,NAME...]] [--bag FILE] [--out DIR] [--every N]
//                     [--incremental-only] [--pose-errors METRES:DEGREES] [--set OPTION=VALUE ...]
// --set takes any mapper option of the option table (doc/parameters.md), e.g. --set p_free=0.45.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bag_scans.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/option_table.h"
#include "octo_slice_mapper/sim/session.h"
#include "peer_maps.h"

namespace osm = octo_slice_mapper;
using Clock = std::chrono::steady_clock;

namespace {

struct Dataset {
  std::string name, file;
};

bool readBag(const std::string& path, std::vector<osm::Scan>* scans) {
  osm::tools::BagScans bag;
  std::string error;
  if (!osm::tools::readBagScans(path, "scan", "odom", &bag, &error)) {
    std::fprintf(stderr, "bench_map_quality: %s\n", error.c_str());
    return false;
  }
  *scans = std::move(bag.scans);
  return true;
}

// A CARMEN log's scans, or a bag's (by the name's ending), or for "sim:office:D[:S:A]" the
// simulator's tour moved by D metres in x and y (its walls lie on round coordinates, so on cell
// boundaries: moved, they lie inside cells as a real building's mostly do), each scan's recorded
// pose then off its true one by Gaussian errors of S metres in x and y and A degrees in heading
// (as a corrected log's poses are: its scans were taken where the poses do not quite say).
bool readScans(const std::string& path, std::vector<osm::Scan>* scans) {
  if (path == "sim:real_robot") {
    // Each scan placed where the robot's odometry (dead reckoning) says, as tf gives it to the node.
    const osm::sim::SimulatedSession session(osm::sim::FloorPlan::office(), osm::sim::SessionSpec::realRobotTour());
    const std::vector<osm::sim::Pose3D> odometry = osm::sim::deadReckoned(session.poses(), osm::sim::DeadReckoning());
    *scans = session.allScans();
    std::size_t k = 0;
    for (osm::Scan& scan : *scans) {
      while (k + 1 < session.poses().size() && session.poses()[k + 1].t <= scan.stamp) ++k;
      const osm::sim::Pose2D& truth = session.poses()[k];
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
      base.translate(Eigen::Vector3d(truth.x, truth.y, 0.0));
      base.rotate(Eigen::AngleAxisd(truth.yaw, Eigen::Vector3d::UnitZ()));
      const Eigen::Isometry3d mount = base.inverse() * session.laserPose(truth);
      scan.sensor_pose = odometry[k].pose * mount;
    }
    return true;
  }
  const std::string sim = "sim:office:";
  if (path.compare(0, sim.size(), sim) == 0) {
    double shift = 0.0, sigma_xy = 0.0, sigma_deg = 0.0;
    std::sscanf(path.c_str() + sim.size(), "%lf:%lf:%lf", &shift, &sigma_xy, &sigma_deg);
    *scans = osm::sim::SimulatedSession(osm::sim::FloorPlan::office(), osm::sim::SessionSpec::officeTour()).allScans();
    for (osm::Scan& scan : *scans) scan.sensor_pose.translation() += Eigen::Vector3d(shift, shift, 0.0);
    if (sigma_xy > 0.0 || sigma_deg > 0.0) {
      osm::sim::PoseErrors errors;
      errors.sigma_xy = sigma_xy;
      errors.sigma_yaw = sigma_deg * M_PI / 180.0;
      osm::sim::addPoseErrors(scans, errors);
    }
    return true;
  }
  if (path.size() > 4 && path.compare(path.size() - 4, 4, ".bag") == 0) return readBag(path, scans);
  osm::CarmenLogReader reader;
  std::string error;
  if (!reader.open(path, &error)) {
    std::fprintf(stderr, "bench_map_quality: %s\n", error.c_str());
    return false;
  }
  osm::LogScan record;
  while (reader.next(&record)) scans->push_back(record.scan);
  return true;
}

struct Row {
  std::string map;
  osm::HeldOutScore score;
  double seconds;
};

void report(const std::string& data, const Row& r) {
  const osm::HeldOutScore& s = r.score;
  std::printf("| %s | %s | %.4f | %.4f | %.3f | %.3f | %.3f | %.3f | %.1f |\n", data.c_str(), r.map.c_str(),
              s.within_10cm, s.within_25cm, s.mean_abs_error, s.too_short, s.too_long, s.unknown_first, r.seconds);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  std::string data_dir = std::getenv("OSM_DATA_DIR") ? std::getenv("OSM_DATA_DIR") : "../shared/data";
  std::string only, out_dir, bag, pose_errors = "0.02:0.5";
  std::vector<std::string> settings;
  bool incremental_only = false;
  osm::HoldOut hold{10, 5};
  osm::MapperOptions options;  // the defaults, but for the models' settings given below
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--incremental-only") incremental_only = true;
    else if (a == "--data" && has_value) data_dir = argv[++i];
    else if (a == "--only" && has_value) only = argv[++i];
    else if (a == "--bag" && has_value) bag = argv[++i];
    else if (a == "--out" && has_value) out_dir = argv[++i];
    else if (a == "--every" && has_value) hold.every = std::atoi(argv[++i]);
    else if (a == "--pose-errors" && has_value) pose_errors = argv[++i];
    else if (a == "--set" && has_value) settings.push_back(argv[++i]);
    else {
      std::fprintf(stderr, "usage: bench_map_quality [--data DIR] [--only NAME[,NAME...]] [--bag FILE] [--out DIR] "
                           "[--every N] [--incremental-only] [--pose-errors METRES:DEGREES] [--set OPTION=VALUE ...]\n");
      return 2;
    }
  }
  for (const std::string& setting : settings) {
    const std::size_t eq = setting.find('=');
    bool found = false;
    for (const auto& spec : osm::mapperOptionTable()) {
      if (eq == std::string::npos || setting.compare(0, eq, spec.name) != 0 || std::strlen(spec.name) != eq) continue;
      found = osm::setOptionFromText(spec.field(options), setting.substr(eq + 1));
    }
    if (!found) {
      std::fprintf(stderr, "bench_map_quality: --set %s: no such mapper option, or a bad value\n", setting.c_str());
      return 2;
    }
  }
  std::vector<Dataset> datasets = {{"intel", data_dir + "/intel_corrected/intel-corrected.log.gz"},
                                   {"fr079", data_dir + "/fr079_corrected/freiburg-079-corrected.log.gz"},
                                   {"acapulco", data_dir + "/acapulco_corrected/acapulco-corrected.log.gz"},
                                   {"campus", data_dir + "/freiburg_campus_corrected/freiburg-campus-corrected.log.gz"},
                                   {"sim_office", "sim:office:0"},
                                   {"sim_office_half_cell", "sim:office:0.025"},
                                   {"sim_office_pose_errors", "sim:office:0.025:" + pose_errors},
                                   {"sim_real_robot", "sim:real_robot"}};
  if (!bag.empty()) {
    const std::size_t slash = bag.find_last_of('/');
    datasets = {{bag.substr(slash == std::string::npos ? 0 : slash + 1), bag}};
  }
  std::printf("| data | map | within 0.10 m | within 0.25 m | mean abs err (m) | too short | too long | unknown first | s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const Dataset& d : datasets) {
    if (!only.empty() && ("," + only + ",").find("," + d.name + ",") == std::string::npos) continue;
    std::vector<osm::Scan> all, train, held;
    if (!readScans(d.file, &all)) return 1;
    if (!out_dir.empty()) std::system(("mkdir -p '" + out_dir + "'").c_str());
    for (std::size_t k = 0; k < all.size(); ++k) (hold.holds(k) ? held : train).push_back(all[k]);
    // `seconds`: what making the map took (the default map's includes the incremental one's).
    auto judge = [&](const std::string& map, const osm::GridImage& grid, double seconds) {
      const osm::GridImage trinary = osm::trinaryOf(grid);
      report(d.name, {map, osm::scoreHeldOut(trinary, held), seconds});
      std::string error;
      if (!out_dir.empty() && !osm::savePgmYaml(grid, out_dir + "/" + d.name + "_" + map, &error)) {
        std::fprintf(stderr, "bench_map_quality: %s\n", error.c_str());
      }
    };
    const auto since = [](Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); };
    auto t0 = Clock::now();
    osm::Mapper mapper(options);
    for (const osm::Scan& s : train) mapper.insert(s);
    const osm::GridImage incremental = osm::gridImageOf(mapper.slice());
    const double incremental_seconds = since(t0);
    if (!incremental_only) {
      t0 = Clock::now();
      const osm::OptimizedMap optimized = mapper.optimize(/*warm_start=*/true);
      judge("default", osm::inFrameOf(optimized.grid, incremental), incremental_seconds + since(t0));
    }
    judge("incremental", incremental, incremental_seconds);
    if (incremental_only) continue;
    t0 = Clock::now();
    const osm::GridImage cold = osm::inFrameOf(mapper.optimize(/*warm_start=*/false).grid, incremental);
    judge("optimized_cold", cold, since(t0));
    t0 = Clock::now();
    const osm::GridImage server =
        osm::bench::octomapServerMap(train, options.resolution, options.slice.min_z, options.slice.max_z);
    judge("octomap_server", server, since(t0));
    t0 = Clock::now();
    const osm::GridImage grid = osm::bench::hitMissGrid(train, options.resolution, false);
    judge("hit_miss_grid", grid, since(t0));
    t0 = Clock::now();
    const osm::GridImage grid_ml = osm::bench::hitMissGrid(train, options.resolution, true);
    judge("hit_miss_grid_ml", grid_ml, since(t0));
  }
  return 0;
}
