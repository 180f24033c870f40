// bench_map_quality: how well each map predicts scans it never saw (issue 18), on the shared CARMEN
// datasets. Every 10th scan from index 5 is held out; the rest build
//   - ours, incremental: the slice the node publishes on /map and saves as .pgm;
//   - ours, optimized: the global pass over the kept scans (start as configured: the default,
//     and the other start for comparison);
//   - octomap_server's method and a dense hit/miss grid (bench/peer_maps.h).
// Each map is judged as exported: the map_server reading of its .pgm (trinaryOf), every held-out
// return cast through it to the first occupied cell (scoreHeldOut, the same rules as
// shared/tools/map_judge). With --out DIR the maps are also written as DIR/<data>_<map>.{pgm,yaml},
// so that the shared judge can check the figures. After the two logs, the simulator's office tour
// (made in-process: data no setting was chosen on), as simulated ("sim_office": its walls on cell
// boundaries), moved by half a cell ("sim_office_half_cell"), and that with its poses 2 cm and
// 0.5 deg off (sigma; "sim_office_pose_errors": as a corrected log's; --pose-errors sets them).
// --bag FILE judges a bag's scans instead (topic "scan", placed with the bag's tf in frame
// "odom"), such as the real-robot tour simulate_session --real-robot writes.
//
//   bench_map_quality [--data DIR] [--only intel|fr079|sim_office|sim_office_half_cell|sim_office_pose_errors]
//                     [--bag FILE] [--out DIR] [--every N] [--incremental-only] [--pose-errors METRES:DEGREES]
//                     [--p-occupied P] [--p-free P]   (the inverse model's; default 0.75 / 0.4)
//                     [--forward-sigma-base M] [--forward-sigma-per-meter M] [--z-rand Z]   (the pass's)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bag_scans.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/mapper.h"
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
    else if (a == "--p-occupied" && has_value) options.insert.model.p_occupied = std::atof(argv[++i]);
    else if (a == "--p-free" && has_value) options.insert.model.p_free = std::atof(argv[++i]);
    else if (a == "--forward-sigma-base" && has_value) options.optimizer.model.sigma_base = std::atof(argv[++i]);
    else if (a == "--forward-sigma-per-meter" && has_value) options.optimizer.model.sigma_per_meter = std::atof(argv[++i]);
    else if (a == "--z-rand" && has_value) options.optimizer.model.z_rand = std::atof(argv[++i]);
    else {
      std::fprintf(stderr, "usage: bench_map_quality [--data DIR] [--only intel|fr079|sim_office|sim_office_half_cell|sim_office_pose_errors] "
                           "[--bag FILE] [--out DIR] [--every N] [--incremental-only] [--pose-errors METRES:DEGREES]\n"
                           "       [--p-occupied P] [--p-free P] [--forward-sigma-base M] "
                           "[--forward-sigma-per-meter M] [--z-rand Z]\n");
      return 2;
    }
  }
  std::vector<Dataset> datasets = {{"intel", data_dir + "/intel_corrected/intel-corrected.log.gz"},
                                   {"fr079", data_dir + "/fr079_corrected/freiburg-079-corrected.log.gz"},
                                   {"sim_office", "sim:office:0"},
                                   {"sim_office_half_cell", "sim:office:0.025"},
                                   {"sim_office_pose_errors", "sim:office:0.025:" + pose_errors}};
  if (!bag.empty()) {
    const std::size_t slash = bag.find_last_of('/');
    datasets = {{bag.substr(slash == std::string::npos ? 0 : slash + 1), bag}};
  }
  std::printf("| data | map | within 0.10 m | within 0.25 m | mean abs err (m) | too short | too long | unknown first | s |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const Dataset& d : datasets) {
    if (!only.empty() && only != d.name) continue;
    std::vector<osm::Scan> all, train, held;
    if (!readScans(d.file, &all)) return 1;
    if (!out_dir.empty()) std::system(("mkdir -p '" + out_dir + "'").c_str());
    for (std::size_t k = 0; k < all.size(); ++k) (hold.holds(k) ? held : train).push_back(all[k]);
    auto judge = [&](const std::string& map, const osm::GridImage& grid, Clock::time_point t0) {
      const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
      const osm::GridImage trinary = osm::trinaryOf(grid);
      report(d.name, {map, osm::scoreHeldOut(trinary, held), seconds});
      std::string error;
      if (!out_dir.empty() && !osm::savePgmYaml(grid, out_dir + "/" + d.name + "_" + map, &error)) {
        std::fprintf(stderr, "bench_map_quality: %s\n", error.c_str());
      }
    };
    auto t0 = Clock::now();
    osm::Mapper mapper(options);
    for (const osm::Scan& s : train) mapper.insert(s);
    const osm::GridImage incremental = osm::gridImageOf(mapper.slice());
    judge("incremental", incremental, t0);
    if (incremental_only) continue;
    for (bool warm : {true, false}) {
      t0 = Clock::now();
      const osm::OptimizedMap optimized = mapper.optimize(warm);
      judge(warm ? "optimized_warm" : "optimized_cold", osm::inFrameOf(optimized.grid, incremental), t0);
    }
    t0 = Clock::now();
    judge("octomap_server", osm::bench::octomapServerMap(train, options.resolution, options.slice.min_z,
                                                          options.slice.max_z), t0);
    t0 = Clock::now();
    judge("hit_miss_grid", osm::bench::hitMissGrid(train, options.resolution, false), t0);
    t0 = Clock::now();
    judge("hit_miss_grid_ml", osm::bench::hitMissGrid(train, options.resolution, true), t0);
  }
  return 0;
}
