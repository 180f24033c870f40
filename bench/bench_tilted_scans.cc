// bench_tilted_scans: what a real robot's tf does to insertion speed. The same
// simulated session mapped twice in one process: once with level scans, once
// with each scan through a tf chain built like a real robot's: odom -> base_link with the
// session's x, y, yaw plus IMU-style roll and pitch noise (sigma 0.6 deg, at most 1.1 deg) and a
// base height that moves by a centimetre or two; base_link -> laser a static mount 0.10 m forward,
// 0.26 m up, yawed 0.02 rad. The lidar is RPLIDAR-like: 720 beams over 360 deg, 12 m, REP 117
// (+inf for no return). Prints medians over repetitions (ms per scan) and their ratio, and the
// median of each repetition's own ratio (the two sessions timed one after the other, the order
// turned every repetition).
//
//   bench_tilted_scans [--repeats N] [--resolution M] [--interleave K] [--cold-mb MB] [--pause-ms MS]
//                      [--slice-report DIR] [--tilted-only | --level-only]
//
// --interleave K (default 32): the two sessions are mapped side by side, K scans of one, then K
// of the other (two mappers); 0 maps one whole session after the other. In turns, the host's
// changing speed moves both alike: on these virtual machines the speed changes within a run by
// more than the difference measured, and turns keep the two sessions' shares of it equal.
//
// --cold-mb MB: between two scans (not timed), MB of other memory is written and read, as the
// other threads and processes of a live node do between a lidar's scans (the background pass,
// the bag player, roscore): each scan then starts with cold caches, as in the node.
// --pause-ms MS: the thread sleeps MS between two scans (not timed), as the node's scan thread
// waits for the next scan: on this 2-core virtual machine a core left idle for a few
// milliseconds comes back slower for the next scan (likely its caches taken by other work).
// Without either, scans follow each other at once and find their data still cached.
//
// --slice-report DIR: what the tilt does to the slice instead of timing: the level session's
// slice against the tilted one's, with the default band (0.16-0.36 m) and wider ones, as counts
// of the level slice's occupied cells the tilted slice also has occupied, and pictures in DIR.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

using Clock = std::chrono::steady_clock;
namespace osm = octo_slice_mapper;

namespace {

// The scans as a REP 117 driver sends them: a reading at range_max is +inf.
std::vector<osm::Scan> rep117(std::vector<osm::Scan> scans) {
  for (osm::Scan& s : scans) {
    for (float& r : s.ranges) {
      if (r >= s.range_max) r = std::numeric_limits<float>::infinity();
    }
  }
  return scans;
}

// Each scan's laser pose through a real robot's chain (see the header).
std::vector<osm::Scan> throughRealTf(std::vector<osm::Scan> scans, const osm::sim::LidarSpec& lidar) {
  std::mt19937 rng(7);
  std::normal_distribution<double> tilt(0.0, 0.6 * M_PI / 180.0), height(0.0, 0.01);
  const double max_tilt = 1.1 * M_PI / 180.0;
  Eigen::Isometry3d level_mount = Eigen::Isometry3d::Identity();
  level_mount.translation() = Eigen::Vector3d(lidar.mount_x, 0.0, lidar.mount_z);
  Eigen::Isometry3d mount = level_mount;
  mount.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()));
  for (osm::Scan& s : scans) {
    const Eigen::Isometry3d base = s.sensor_pose * level_mount.inverse();  // the session's odom -> base_link
    Eigen::Isometry3d tilted = base;
    tilted.translation().z() += std::clamp(height(rng), -0.02, 0.02);
    tilted.rotate(Eigen::AngleAxisd(std::clamp(tilt(rng), -max_tilt, max_tilt), Eigen::Vector3d::UnitX()));
    tilted.rotate(Eigen::AngleAxisd(std::clamp(tilt(rng), -max_tilt, max_tilt), Eigen::Vector3d::UnitY()));
    // The mount's yaw turned back in the scan's angles: the same world rays as the level run.
    s.sensor_pose = tilted * mount;
    s.angle_min -= 0.02f;
  }
  return scans;
}

// Writes and reads all of `memory` (a stride of one cache line): what other work between two
// scans does to the caches.
std::uint64_t evictCaches(std::vector<std::uint64_t>* memory) {
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < memory->size(); i += 8) sum += ++(*memory)[i];
  return sum;
}

// One session mapped into a mapper of its own, its insertions timed: scans one after the other
// (next) or a block at a time between another session's blocks (--interleave).
class TimedSession {
 public:
  TimedSession(const std::vector<osm::Scan>& scans, double resolution, double cold_mb, double pause_ms)
      : scans_(scans), mapper_(optionsFor(resolution)), pause_ms_(pause_ms),
        other_(std::size_t(cold_mb * (1 << 20)) / sizeof(std::uint64_t)) {}
  bool done() const { return next_ == scans_.size(); }
  // Inserts the next `count` scans (fewer at the end).
  void insertNext(std::size_t count) {
    for (const std::size_t end = std::min(scans_.size(), next_ + count); next_ < end; ++next_) {
      if (!other_.empty()) sink_ = sink_ + evictCaches(&other_);
      if (pause_ms_ > 0.0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(pause_ms_));
      const auto t0 = Clock::now();
      const osm::InsertResult r = mapper_.insert(scans_[next_]);
      spent_ += Clock::now() - t0;
      inserted_ += r.ok();
      changed_ += r.updated_keys.size();
    }
    if (done()) {
      const auto t0 = Clock::now();
      mapper_.tree();  // what a reader of the octree would wait for
      spent_ += Clock::now() - t0;
    }
  }
  // ms per scan; also the scans inserted, the voxel updates per scan and the voxels per scan whose
  // value changed (those cost a dirty mark, a write into the octree and a slice column).
  double msPerScan(std::size_t* inserted, double* updates_per_scan, double* changed_per_scan) const {
    *inserted = inserted_;
    *updates_per_scan = double(mapper_.stats().voxel_updates) / scans_.size();
    *changed_per_scan = double(changed_) / scans_.size();
    return std::chrono::duration<double, std::milli>(spent_).count() / scans_.size();
  }

 private:
  static osm::MapperOptions optionsFor(double resolution) {
    osm::MapperOptions options;
    options.resolution = resolution;
    options.keep_scans = false;
    return options;
  }
  const std::vector<osm::Scan>& scans_;
  osm::Mapper mapper_;
  double pause_ms_;
  std::vector<std::uint64_t> other_;
  volatile std::uint64_t sink_ = 0;
  std::size_t next_ = 0, inserted_ = 0, changed_ = 0;
  Clock::duration spent_{};
};

std::unique_ptr<osm::Mapper> mapAll(const std::vector<osm::Scan>& scans, double min_z, double max_z) {
  osm::MapperOptions options;
  options.keep_scans = false;
  options.slice.min_z = min_z;
  options.slice.max_z = max_z;
  auto mapper = std::make_unique<osm::Mapper>(options);
  for (const osm::Scan& s : scans) mapper->insert(s);
  return mapper;
}

// Of the reference slice's occupied cells (> 65 %), the share `other` has occupied, and the share
// it has unknown; of `other`'s occupied cells, the share the reference has free (< 20 %).
void compareSlices(const char* what, const osm::SliceGrid& reference, const osm::SliceGrid& other) {
  std::size_t occupied = 0, kept = 0, lost_unknown = 0, other_occupied = 0, spurious = 0, free = 0, free_kept = 0;
  const double res = reference.resolution();
  for (int j = 0; j < reference.height(); ++j) {
    for (int i = 0; i < reference.width(); ++i) {
      const double x = reference.originX() + (i + 0.5) * res, y = reference.originY() + (j + 0.5) * res;
      const int a = reference.at(i, j), b = other.valueAt(x, y);
      if (a > 65) {
        ++occupied;
        kept += b > 65;
        lost_unknown += b == osm::kUnknownCell;
      }
      if (a >= 0 && a < 20) {
        ++free;
        free_kept += b >= 0 && b < 20;
      }
      if (b > 65) {
        ++other_occupied;
        spurious += a >= 0 && a < 20;
      }
    }
  }
  std::printf("%-30s level's occupied cells kept occupied %5.1f %% (unknown %4.1f %%), its free cells kept free "
              "(< 20 %%) %5.1f %%; its occupied cells free in level's %4.1f %%\n",
              what, 100.0 * kept / std::max<std::size_t>(1, occupied), 100.0 * lost_unknown / std::max<std::size_t>(1, occupied),
              100.0 * free_kept / std::max<std::size_t>(1, free), 100.0 * spurious / std::max<std::size_t>(1, other_occupied));
}

int sliceReport(const std::vector<osm::Scan>& level, const std::vector<osm::Scan>& tilted, const std::string& dir) {
  const std::unique_ptr<osm::Mapper> reference = mapAll(level, 0.16, 0.36);
  std::string error;
  osm::savePng(osm::gridImageOf(reference->slice()), dir + "/tilt_level.png", &error);
  for (const auto& band : std::vector<std::pair<double, double>>{{0.16, 0.36}, {0.06, 0.46}, {0.0, 0.6}}) {
    const std::unique_ptr<osm::Mapper> mapper = mapAll(tilted, band.first, band.second);
    char what[96];
    std::snprintf(what, sizeof what, "tilted, band %.2f-%.2f m:", band.first, band.second);
    compareSlices(what, reference->slice(), mapper->slice());
    char name[64];
    std::snprintf(name, sizeof name, "/tilt_band_%.2f_%.2f.png", band.first, band.second);
    if (!osm::savePng(osm::gridImageOf(mapper->slice()), dir + name, &error)) std::fprintf(stderr, "%s\n", error.c_str());
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 5;
  double resolution = 0.05, cold_mb = 0.0, pause_ms = 0.0;
  std::size_t interleave = 32;
  bool tilted_only = false, level_only = false;  // for profiling one path alone
  std::string slice_dir;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--tilted-only") tilted_only = true;
    else if (arg == "--level-only") level_only = true;
    else if (arg == "--slice-report" && has_value) slice_dir = argv[++i];
    else if (arg == "--repeats" && has_value) repeats = std::max(1, std::stoi(argv[++i]));
    else if (arg == "--resolution" && has_value) resolution = std::stod(argv[++i]);
    else if (arg == "--cold-mb" && has_value) cold_mb = std::max(0.0, std::stod(argv[++i]));
    else if (arg == "--pause-ms" && has_value) pause_ms = std::max(0.0, std::stod(argv[++i]));
    else if (arg == "--interleave" && has_value) interleave = std::stoul(argv[++i]);
    else {
      std::fprintf(stderr, "bench_tilted_scans: unknown or incomplete argument '%s'\n", arg.c_str());
      return 2;
    }
  }
  osm::sim::SessionSpec spec = osm::sim::SessionSpec::officeTour();
  spec.lidar.beams = 720;
  spec.lidar.angle_min = static_cast<float>(-M_PI);
  spec.lidar.angle_increment = static_cast<float>(2.0 * M_PI / 720.0);
  spec.lidar.range_max = 12.0f;
  spec.lidar.spurious_no_return_probability = 0.1;  // glass and black surfaces: +inf
  const osm::sim::SimulatedSession session(osm::sim::FloorPlan::office(), spec);
  const std::vector<osm::Scan> level = rep117(session.allScans());
  const std::vector<osm::Scan> tilted = throughRealTf(level, spec.lidar);
  if (!slice_dir.empty()) return sliceReport(level, tilted, slice_dir);
  std::vector<double> level_ms, tilted_ms;
  std::size_t level_ok = 0, tilted_ok = 0;
  double level_updates = 0.0, tilted_updates = 0.0, level_changed = 0.0, tilted_changed = 0.0;
  // Each repetition times both sessions, the order turned every repetition, and gives a ratio of
  // its own: on these virtual machines the speed moves within a run (one run's
  // repetitions gave tilted / level from 0.86 to 1.70), and timings close in time compare better.
  std::vector<double> ratios;
  for (int r = 0; r < repeats; ++r) {
    TimedSession level_session(level, resolution, cold_mb, pause_ms);
    TimedSession tilted_session(tilted, resolution, cold_mb, pause_ms);
    if (level_only || tilted_only) {
      (level_only ? level_session : tilted_session).insertNext(level.size());
    } else {
      // Whole sessions one after the other, or blocks of scans in turn (--interleave); the order
      // of the two turned every repetition.
      const std::size_t block = interleave > 0 ? interleave : level.size();
      TimedSession* order[2] = {&level_session, &tilted_session};
      if (r % 2 == 1) std::swap(order[0], order[1]);
      while (!level_session.done() || !tilted_session.done()) {
        order[0]->insertNext(block);
        order[1]->insertNext(block);
      }
    }
    level_ms.push_back(tilted_only ? 1.0 : level_session.msPerScan(&level_ok, &level_updates, &level_changed));
    tilted_ms.push_back(level_only ? 1.0 : tilted_session.msPerScan(&tilted_ok, &tilted_updates, &tilted_changed));
    ratios.push_back(tilted_ms.back() / level_ms.back());
    std::fprintf(stderr, "\rrepetition %d/%d", r + 1, repeats);
  }
  std::fprintf(stderr, "\n");
  const double a = osm::bench::median(level_ms), b = osm::bench::median(tilted_ms);
  std::string between;
  if (cold_mb > 0.0) between += ", caches made cold between scans (" + std::to_string(int(cold_mb)) + " MB)";
  if (pause_ms > 0.0) between += ", a pause of " + std::to_string(pause_ms).substr(0, 5) + " ms between scans";
  if (interleave > 0) between += ", the sessions in turns of " + std::to_string(interleave) + " scans";
  std::printf("%zu scans of 720 beams (REP 117, 12 m), %.2f m, median of %d%s\n", level.size(), resolution, repeats,
              between.c_str());
  std::printf("level scans:                    %.3f ms/scan (%zu inserted, %.0f voxel updates per scan, %.0f changed)\n", a,
              level_ok, level_updates, level_changed);
  std::printf("through a real robot's tf (~1 deg pitch/roll): %.3f ms/scan (%zu inserted, %.0f voxel updates per scan, "
              "%.0f changed)\n",
              b, tilted_ok, tilted_updates, tilted_changed);
  std::printf("tilted / level: %.2f (the medians'; the repetitions' own ratios: median %.2f, %.2f-%.2f)\n", b / a,
              osm::bench::median(ratios), *std::min_element(ratios.begin(), ratios.end()),
              *std::max_element(ratios.begin(), ratios.end()));
  return 0;
}
