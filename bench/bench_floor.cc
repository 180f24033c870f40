// The floor found, not assumed: the navigation slice (0.05-0.80 m above the floor) that depth
// frames give, judged where the floor is not at the fixed frame's z = 0 or not level.
//
// Simulated: the office room (sim/depth_camera.h) seen by a camera on a loop, in variants (as is;
// the world 1.5 m down; the world turned 1.5 degrees; a ramp; flying pixels, filtered and not),
// each with Kinect depth noise, against the truth: the cells whose column holds a solid
// 0.05-0.80 m above the floor under it, and the room's walls.
// Real: the two TUM RGB-D sequences in ../shared/data (OSM_DATA_DIR), as recorded, moved 1.5 m
// down and turned 1.5 degrees (as tum2bag's --lower and --tilt), against a reference built
// without any floor finding: OctoMap's own discretized insertPointCloud of the untouched
// sequence, its occupied voxels 0.15-0.80 m above the recorded floor (z = 0) projected.
// Precision and recall with one cell of tolerance (map_evaluation.h); the variants' slices are
// compared in x-y, where the turn moves obstacles by at most 2 cm.
//
//   bench_floor [--sim-frames N] [--seed S] [--every K] [--no-real] [--no-sim] [--assumed-floor]
//               [--held-out] [--reference-range M] [--reference-min-z M] [--json] [--pictures DIR]
// --seed: the simulated frames' noise and mixed pixels drawn anew (7 unless given), to see how
// much of a simulated row's score is its draw.
// --assumed-floor: the rules of a map without floor finding (the floor at z = 0, no noise model,
// no flying-pixel filter), for comparison in the same run. ms/frame: one thread, conversion,
// flying-pixel test and insertion (its share: the column "ms"); ref ms: OctoMap's insertion.
// phantom (the hand-held camera's office rows in every frame of reference, the ramp and the
// flying-pixel rows): occupied voxels of the octree more than 0.15 m from every surface of the
// scene (phantomVoxels); "-" elsewhere.
// --held-out: four more frames of reference (variants()) and a robot's camera in the simulator
// (0.35 m up, pitched 0.10 rad), a check that the defaults carry over; that camera driving
// straight up to a platform 8 cm high across the room's far end (robotToPlatform), and up to an
// edge with the floor 1 m lower beyond it (robotToTheEdge), which the camera alone gets wrong;
// and the robot's rows again with its base_footprint as each frame's ground point
// (floor_base_frame), rows named "..., base".
#include <octomap/OcTree.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "bench_common.h"
#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/internal/flying_pixels.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/slice_grid.h"
#include "tools/tum_sequence.h"

namespace osm = octo_slice_mapper;

namespace {

struct Frame {
  Eigen::Isometry3d optical_in_world;
  std::vector<Eigen::Vector3f> organized;  // optical frame, NaN kept
  int width = 0, height = 0;
};

struct Variant {
  std::string name;
  Eigen::Isometry3d world = Eigen::Isometry3d::Identity();  // the world as the map's fixed frame sees it
};

bool held_out = false;  // --held-out: the variants below too, and a robot's camera (in main)

Eigen::Isometry3d turned(double degrees, const Eigen::Vector3d& axis) {
  return Eigen::Isometry3d(Eigen::AngleAxisd(degrees * M_PI / 180.0, axis));
}
Eigen::Isometry3d moved(double dz) { return Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, dz)); }

// The issue's three frames of reference.
std::vector<Variant> issueVariants() {
  return {{"as recorded", Eigen::Isometry3d::Identity()},
          {"floor 1.5 m down", moved(-1.5)},
          {"turned 1.5 deg", turned(1.5, Eigen::Vector3d::UnitX())}};
}

// The issue's three, and with --held-out four that no default was chosen on: the floor above the
// frame's origin, far below it, turned about the other level axis and by more, and a turn and a
// drop at once. The turns move obstacles in x-y by at most 4 cm (2.5 degrees at 1 m), inside the
// score's one cell of tolerance.
std::vector<Variant> variants() {
  std::vector<Variant> all = issueVariants();
  if (held_out) {
    all.push_back({"floor 0.7 m up", moved(0.7)});
    all.push_back({"floor 4 m down", moved(-4.0)});
    all.push_back({"turned 2.5 deg (y)", turned(2.5, Eigen::Vector3d::UnitY())});
    all.push_back({"1 deg (x, y), 1.2 m down", moved(-1.2) * turned(1.0, Eigen::Vector3d(1.0, 1.0, 0.0).normalized())});
  }
  return all;
}

std::string pictures;  // --pictures DIR: each variant's slice as a PNG

std::string fileName(std::string text) {
  for (char& c : text) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return text;
}

struct Outcome {
  osm::OccupancyScore score;
  double ms_per_frame = 0.0;
  osm::FloorStatus floor;
  std::uint64_t flying = 0;
  double flying_ms = 0.0;  // of ms_per_frame: the flying-pixel filter
  long long phantoms = -1;  // occupied voxels away from every surface (phantomVoxels); -1: not measured
};

// How far a point is from the surface of `box`, from inside or outside.
double distanceToSurface(const osm::sim::Box& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d outside = (box.min - p).cwiseMax(p - box.max).cwiseMax(0.0);
  if (outside.squaredNorm() > 0.0) return outside.norm();
  return (p - box.min).cwiseMin(box.max - p).minCoeff();
}

// Phantom voxels: occupied voxels of `tree` (occupiedVoxels: a pruned node's voxels one by one)
// whose centre lies farther than `margin` from every surface of `scene` (the room's faces, the
// ramp, the solids), the map being `world` of the scene's frame. Mixed pixels float between a
// depth edge and what lies behind it; a real surface's voxels lie within its depth noise (three
// sigmas: 0.1 m at 4.5 m) and half a voxel's diagonal of it.
long long phantomVoxels(const octomap::OcTree& tree, const osm::sim::BoxScene& scene, const Eigen::Isometry3d& world,
                        double margin) {
  const Eigen::Isometry3d to_scene = world.inverse();
  long long count = 0;
  for (const osm::OccupiedVoxel& v : osm::occupiedVoxels(tree)) {
    const Eigen::Vector3d p = to_scene * Eigen::Vector3d(v.x, v.y, v.z);
    double nearest = distanceToSurface(scene.room, p);
    if (scene.ramp) nearest = std::min(nearest, std::abs(p.z() - scene.floorAt(p.x())));
    for (const osm::sim::Box& solid : scene.solids) nearest = std::min(nearest, distanceToSurface(solid, p));
    count += nearest > margin;
  }
  return count;
}

// Our navigation slice of `frames` seen through `world`, scored against `truth`.
bool assumed_floor = false;  // --assumed-floor: the rules without floor finding (z = 0, fixed band, no noise model)

// `ground_below` > 0: each frame's ground point (SensorCloud::ground, a robot's base_footprint) lies
// that far below the camera in the world.
// `scene`: the simulated scene, for phantomVoxels.
Outcome mapAndScore(const std::vector<Frame>& frames, const Eigen::Isometry3d& world, const osm::GridImage& truth,
                    bool filter_flying, const std::string& picture = "", double ground_below = 0.0,
                    const osm::sim::BoxScene* scene = nullptr) {
  osm::MapperOptions options;
  options.keep_scans = false;
  if (assumed_floor) {
    options.floor.find = false;
    options.insert.cloud_mark_sigmas = 0.0;
    filter_flying = false;
  }
  options.slice.min_z = osm::kNavigationBandMinZ;
  options.slice.max_z = osm::kNavigationBandMaxZ;
  osm::Mapper mapper(options);
  osm::FlyingPixelOptions flying;
  Outcome out;
  std::vector<double> ms, flying_ms;
  for (const Frame& f : frames) {
    const auto t0 = std::chrono::steady_clock::now();
    const Eigen::Isometry3d pose = world * f.optical_in_world;
    const Eigen::Isometry3f to_map = pose.cast<float>();
    std::vector<std::uint8_t> drop;
    if (filter_flying) out.flying += osm::flagFlyingPixels(f.organized, f.width, f.height, flying, &drop);
    flying_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    osm::SensorCloud cloud;
    cloud.origin = pose.translation();
    if (ground_below > 0.0) {
      cloud.ground = world * (f.optical_in_world.translation() - Eigen::Vector3d(0.0, 0.0, ground_below));
    }
    cloud.points.reserve(f.organized.size());
    for (std::size_t i = 0; i < f.organized.size(); ++i) {
      if (f.organized[i].allFinite() && (drop.empty() || !drop[i])) cloud.points.push_back(to_map * f.organized[i]);
    }
    mapper.insert(cloud);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  out.ms_per_frame = osm::bench::median(ms);
  out.flying_ms = osm::bench::median(flying_ms);
  out.floor = mapper.floor().status();
  if (scene) out.phantoms = phantomVoxels(mapper.tree(), *scene, world, 0.15);
  const osm::GridImage slice = osm::gridImageOf(mapper.slice());
  out.score = osm::scoreOccupancy(slice, truth, 1);
  std::string error;
  if (!pictures.empty() && !picture.empty()) {
    if (!osm::savePng(slice, pictures + "/" + fileName(picture) + ".png", &error)) std::fprintf(stderr, "bench_floor: %s\n", error.c_str());
    // The truth's obstacles the slice misses (black), finds (grey); the rest white.
    osm::GridImage misses = truth;
    for (int j = 0; j < truth.height; ++j) {
      for (int i = 0; i < truth.width; ++i) {
        std::int8_t& cell = misses.cells[std::size_t(j) * truth.width + i];
        if (truth.at(i, j) <= 50) {
          cell = 0;
          continue;
        }
        const double x = truth.origin_x + (i + 0.5) * 0.05, y = truth.origin_y + (j + 0.5) * 0.05;
        bool found = false;
        for (int dj = -1; dj <= 1; ++dj) {
          for (int di = -1; di <= 1; ++di) found = found || mapper.slice().valueAt(x + di * 0.05, y + dj * 0.05) > 50;
        }
        cell = found ? 60 : 100;
      }
    }
    osm::savePng(misses, pictures + "/" + fileName(picture) + "_misses.png", &error);
  }
  return out;
}

// OctoMap's discretized insertion of the untouched frames (returns beyond max_range cut, as
// OctoMap cuts them: cleared up to it), its occupied voxels with z in [lo, hi] projected (100),
// the other known columns of the band free (0).
osm::GridImage octomapReference(const std::vector<Frame>& frames, double lo, double hi, double max_range,
                                double* ms_per_frame) {
  octomap::OcTree tree(0.05);
  std::vector<double> ms;
  for (const Frame& f : frames) {
    const auto t0 = std::chrono::steady_clock::now();
    octomap::Pointcloud cloud;
    for (const Eigen::Vector3f& p : f.organized) {
      if (!p.allFinite()) continue;
      const Eigen::Vector3d w = f.optical_in_world * p.cast<double>();
      cloud.push_back(float(w.x()), float(w.y()), float(w.z()));
    }
    const Eigen::Vector3d o = f.optical_in_world.translation();
    tree.insertPointCloud(cloud, octomap::point3d(float(o.x()), float(o.y()), float(o.z())), max_range, false, true);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  *ms_per_frame = osm::bench::median(ms);
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    x0 = std::min(x0, it.getX()), y0 = std::min(y0, it.getY()), x1 = std::max(x1, it.getX()), y1 = std::max(y1, it.getY());
  }
  osm::GridImage grid;
  grid.resolution = 0.05;
  grid.origin_x = std::floor(x0 / 0.05) * 0.05 - 0.5, grid.origin_y = std::floor(y0 / 0.05) * 0.05 - 0.5;
  grid.width = int((x1 - grid.origin_x) / 0.05) + 10, grid.height = int((y1 - grid.origin_y) / 0.05) + 10;
  grid.cells.assign(std::size_t(grid.width) * grid.height, osm::kUnknownCell);
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const double size = it.getSize();
    if (it.getZ() + size / 2 < lo || it.getZ() - size / 2 > hi) continue;
    const bool occupied = tree.isNodeOccupied(*it);
    const int n = std::max(1, int(std::lround(size / 0.05)));
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        const double x = it.getX() - size / 2 + (a + 0.5) * 0.05, y = it.getY() - size / 2 + (b + 0.5) * 0.05;
        const int i = int(std::floor((x - grid.origin_x) / 0.05)), j = int(std::floor((y - grid.origin_y) / 0.05));
        if (i < 0 || j < 0 || i >= grid.width || j >= grid.height) continue;
        std::int8_t& cell = grid.cells[std::size_t(j) * grid.width + i];
        if (occupied) cell = 100;
        else if (cell != 100) cell = 0;
      }
    }
  }
  return grid;
}

// The simulator's truth: columns holding a solid 0.05-0.80 m above the floor under them (the
// scene's floorAt, or `floor_at`), and the room's walls (the cells either side of its boundary).
osm::GridImage simTruth(const osm::sim::BoxScene& scene, const std::function<double(double)>& floor_at = {}) {
  osm::GridImage grid;
  grid.resolution = 0.05;
  grid.origin_x = scene.room.min.x() - 0.5, grid.origin_y = scene.room.min.y() - 0.5;
  grid.width = int((scene.room.max.x() - scene.room.min.x() + 1.0) / 0.05);
  grid.height = int((scene.room.max.y() - scene.room.min.y() + 1.0) / 0.05);
  grid.cells.assign(std::size_t(grid.width) * grid.height, 0);
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const double x0 = grid.origin_x + i * 0.05, y0 = grid.origin_y + j * 0.05, x1 = x0 + 0.05, y1 = y0 + 0.05;
      const double floor = floor_at ? floor_at(0.5 * (x0 + x1)) : scene.floorAt(0.5 * (x0 + x1));
      bool occupied = false;
      for (const osm::sim::Box& b : scene.solids) {
        if (b.max.x() > x0 && b.min.x() < x1 && b.max.y() > y0 && b.min.y() < y1 && b.max.z() > floor + 0.05 &&
            b.min.z() < floor + 0.80) {
          occupied = true;
        }
      }
      const osm::sim::Box& r = scene.room;
      const bool inside_x = x1 > r.min.x() && x0 < r.max.x(), inside_y = y1 > r.min.y() && y0 < r.max.y();
      const auto near = [](double edge, double a, double b) { return a <= edge + 0.05 && b >= edge - 0.05; };
      if ((inside_y && (near(r.min.x(), x0, x1) || near(r.max.x(), x0, x1))) ||
          (inside_x && (near(r.min.y(), y0, y1) || near(r.max.y(), y0, y1)))) {
        occupied = true;
      }
      grid.cells[std::size_t(j) * grid.width + i] = occupied ? 100 : 0;
    }
  }
  return grid;
}

// The simulated camera's frames of `scene` from each optical pose in turn, with flying pixels at
// that share of the depth edges, their noise drawn from one generator seeded with `seed`.
std::vector<Frame> framesAt(const osm::sim::BoxScene& scene, const std::vector<Eigen::Isometry3d>& poses,
                            double flying, unsigned seed) {
  osm::sim::DepthCameraSpec spec;
  spec.flying_pixel_probability = flying;
  std::mt19937 rng(seed);
  std::vector<Frame> frames;
  for (const Eigen::Isometry3d& pose : poses) {
    Frame f;
    f.optical_in_world = pose;
    f.organized = osm::sim::depthFrame(scene, f.optical_in_world, spec, &rng);
    f.width = spec.width, f.height = spec.height;
    frames.push_back(std::move(f));
  }
  return frames;
}

// A camera `height` over the floor under it, pitched `pitch` rad down, on a loop between the
// table and the shelf, looking out. At 1.0 m and 0.45 rad (a hand-held camera) it sees the floor,
// the table's top and the step; at a robot's 0.35 m and 0.10 rad it sees the floor at a graze,
// far returns noisy, and the table from the side.
std::vector<Frame> simFrames(const osm::sim::BoxScene& scene, int count, double flying, unsigned seed,
                             double height = 1.0, double pitch = 0.45) {
  std::vector<Eigen::Isometry3d> poses;
  for (int k = 0; k < count; ++k) {
    const double a = 2.0 * M_PI * k / count;
    const double x = 3.0 + 1.9 * std::cos(a), y = 3.2 + 0.5 * std::sin(a);
    poses.push_back(osm::sim::opticalPose(Eigen::Vector3d(x, y, scene.floorAt(x) + height), a + 0.9, pitch));
  }
  return framesAt(scene, poses, flying, seed);
}

// The office with a platform 8 cm high over its far end (x from 4.2 m, the whole width) in place
// of the small step, and a robot's camera (0.35 m up, pitched 0.10 rad down) driving along y =
// 3.2 m from x = 1.0 to 3.9 m, facing it: near the end the platform's top fills the view.
osm::sim::BoxScene officeWithPlatform() {
  osm::sim::BoxScene scene = osm::sim::BoxScene::officeRoom();
  scene.solids.pop_back();  // the step
  scene.solids.push_back({Eigen::Vector3d(4.2, 0.0, 0.0), Eigen::Vector3d(6.0, 5.0, 0.08)});
  return scene;
}

// The robot's camera (0.35 m up, pitched 0.10 rad down) driving along y from x0 to x1, facing +x.
std::vector<Frame> robotAlongX(const osm::sim::BoxScene& scene, double x0, double x1, double y, int count,
                               unsigned seed) {
  std::vector<Eigen::Isometry3d> poses;
  for (int k = 0; k < count; ++k) {
    const double x = x0 + (x1 - x0) * k / std::max(1, count - 1);
    poses.push_back(osm::sim::opticalPose(Eigen::Vector3d(x, y, 0.35), 0.0, 0.10));
  }
  return framesAt(scene, poses, 0.0, seed);
}

std::vector<Frame> robotToPlatform(const osm::sim::BoxScene& scene, int count, unsigned seed) {
  return robotAlongX(scene, 1.0, 3.9, 3.2, count, seed);
}

bool realFrames(const std::string& folder, const osm::tools::DepthIntrinsics& intrinsics, int every,
                std::vector<Frame>* frames) {
  std::vector<osm::tools::DepthFrame> sequence;
  std::string error;
  if (!osm::tools::readTumSequence(folder, &sequence, &error)) {
    std::fprintf(stderr, "bench_floor: %s: %s (skipped)\n", folder.c_str(), error.c_str());
    return false;
  }
  for (std::size_t i = 0; i < sequence.size(); i += std::size_t(every)) {
    Frame f;
    std::vector<std::uint16_t> pixels;
    if (!osm::tools::readDepthPng(sequence[i].image, &f.width, &f.height, &pixels, &error)) {
      std::fprintf(stderr, "bench_floor: %s (skipped)\n", error.c_str());
      return false;
    }
    f.organized = osm::tools::depthPoints(f.width, f.height, pixels, intrinsics);
    f.optical_in_world = sequence[i].pose;
    frames->push_back(std::move(f));
  }
  return true;
}

std::string json;

void report(const std::string& data, const std::string& variant, const Outcome& o, double reference_ms) {
  const std::string phantoms = o.phantoms < 0 ? "-" : std::to_string(o.phantoms);
  std::printf("  %-22s %-24s %9.3f %7.3f %8zu %8zu %9.2f %9.2f %5llu/%-5llu %8.3f %9llu %6.2f %8s\n", data.c_str(),
              variant.c_str(), o.score.precision, o.score.recall, o.score.map_occupied, o.score.truth_observed,
              o.ms_per_frame, reference_ms, (unsigned long long)o.floor.frames_found,
              (unsigned long long)(o.floor.frames_found + o.floor.frames_without), o.floor.height,
              (unsigned long long)o.flying, o.flying_ms, phantoms.c_str());
  char line[512];
  std::snprintf(line, sizeof line,
                "%s{\"data\": \"%s\", \"variant\": \"%s\", \"precision\": %.4f, \"recall\": %.4f, \"ms_per_frame\": %.3f, "
                "\"reference_ms_per_frame\": %.3f, \"floor_frames\": %llu, \"flying_pixels\": %llu, \"phantom_voxels\": %lld}",
                json.empty() ? "" : ", ", data.c_str(), variant.c_str(), o.score.precision, o.score.recall,
                o.ms_per_frame, reference_ms, (unsigned long long)o.floor.frames_found, (unsigned long long)o.flying,
                o.phantoms);
  json += line;
}

// The office with its floor 1 m lower beyond x = 4.2 m, the whole width, and 4 m longer (a hall
// below a gallery, a loading dock): the room's bottom at z = -1 and a slab up to z = 0 under the
// office. The step is not in it.
constexpr double kEdgeX = 4.2;
osm::sim::BoxScene officeAtAnEdge() {
  osm::sim::BoxScene scene = osm::sim::BoxScene::officeRoom();
  scene.solids.pop_back();  // the step
  scene.room.min.z() = -1.0;
  scene.room.max.x() = 10.0;
  scene.solids.push_back({Eigen::Vector3d(0.0, 0.0, -1.0), Eigen::Vector3d(kEdgeX, 5.0, 0.0)});
  return scene;
}
double floorAtTheEdge(double x) { return x < kEdgeX ? 0.0 : -1.0; }

// The robot's camera driving along y = 2.6 m from x = 0.6 to 3.8 m towards the edge, past the
// table: in its last frames the floor below fills most of the view.
std::vector<Frame> robotToTheEdge(const osm::sim::BoxScene& scene, int count, unsigned seed) {
  return robotAlongX(scene, 0.6, 3.8, 2.6, count, seed);
}

}  // namespace

int main(int argc, char** argv) {
  int sim_frames = 24, every = 1;
  unsigned seed = 7;  // the simulated frames' noise and mixed pixels
  double reference_range = -1.0;  // OctoMap's default: no cut
  double reference_min_z = 0.15;
  bool real = true, simulated = true, as_json = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--sim-frames" && i + 1 < argc) sim_frames = std::max(4, std::atoi(argv[++i]));
    else if (arg == "--seed" && i + 1 < argc) seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else if (arg == "--every" && i + 1 < argc) every = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--no-real") real = false;
    else if (arg == "--assumed-floor") assumed_floor = true;
    else if (arg == "--reference-range" && i + 1 < argc) reference_range = std::atof(argv[++i]);
    else if (arg == "--reference-min-z" && i + 1 < argc) reference_min_z = std::atof(argv[++i]);
    else if (arg == "--no-sim") simulated = false;
    else if (arg == "--json") as_json = true;
    else if (arg == "--held-out") held_out = true;
    else if (arg == "--pictures" && i + 1 < argc) pictures = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: bench_floor [--sim-frames N] [--seed S] [--every K] [--no-real] [--no-sim] [--assumed-floor]\n"
                   "                   [--held-out] [--reference-range M] [--reference-min-z M] [--json] [--pictures DIR]\n");
      return 2;
    }
  }
  std::printf("== the navigation slice (0.05-0.80 m above the floor found), 0.05 m, one cell of tolerance\n");
  std::printf("  %-22s %-24s %9s %7s %8s %8s %9s %9s %11s %8s %9s %6s %8s\n", "data", "variant", "precision", "recall",
              "occupied", "truth", "ms/frame", "ref ms", "floor found", "floor z", "flying", "ms", "phantom");
  if (simulated) {
    const osm::sim::BoxScene office = osm::sim::BoxScene::officeRoom(), ramp = osm::sim::BoxScene::officeRoomWithRamp();
    const std::vector<Frame> frames = simFrames(office, sim_frames, 0.0, seed);
    const osm::GridImage truth = simTruth(office);
    for (const Variant& v : variants()) {
      report("sim office", v.name, mapAndScore(frames, v.world, truth, true, "sim " + v.name, 0.0, &office), 0.0);
    }
    if (held_out) {  // a robot's camera, 0.35 m up, in the issue's three frames of reference
      const std::vector<Frame> robot = simFrames(office, sim_frames, 0.0, seed, 0.35, 0.10);
      for (const Variant& v : issueVariants()) {
        report("sim office", "robot, " + v.name, mapAndScore(robot, v.world, truth, true, "sim robot " + v.name), 0.0);
      }
      // The platform and the edge rows without and with the robot's base_footprint as each frame's
      // ground point (floor_base_frame); each scene's frames and truth made once.
      const osm::sim::BoxScene platform = officeWithPlatform();
      const std::vector<Frame> to_platform = robotToPlatform(platform, sim_frames, seed);
      const osm::GridImage platform_truth = simTruth(platform);
      report("sim office", "robot up to a platform",
             mapAndScore(to_platform, Eigen::Isometry3d::Identity(), platform_truth, true, "sim robot platform"), 0.0);
      for (const Variant& v : issueVariants()) {
        report("sim office", "robot, " + v.name + ", base",
               mapAndScore(robot, v.world, truth, true, "sim robot base " + v.name, 0.35), 0.0);
      }
      report("sim office", "robot up to a platform, base",
             mapAndScore(to_platform, Eigen::Isometry3d::Identity(), platform_truth, true, "sim robot platform base", 0.35),
             0.0);
      const osm::sim::BoxScene edge = officeAtAnEdge();
      const std::vector<Frame> to_edge = robotToTheEdge(edge, sim_frames, seed);
      const osm::GridImage edge_truth = simTruth(edge, floorAtTheEdge);
      report("sim office", "robot up to an edge",
             mapAndScore(to_edge, Eigen::Isometry3d::Identity(), edge_truth, true, "sim robot edge"), 0.0);
      report("sim office", "robot up to an edge, base",
             mapAndScore(to_edge, Eigen::Isometry3d::Identity(), edge_truth, true, "sim robot edge base", 0.35), 0.0);
    }
    report("sim office", "ramp", mapAndScore(simFrames(ramp, sim_frames, 0.0, seed), Eigen::Isometry3d::Identity(),
                                            simTruth(ramp), true, "sim ramp", 0.0, &ramp), 0.0);
    const std::vector<Frame> flying = simFrames(office, sim_frames, 0.5, seed);
    report("sim office", "flying pixels",
           mapAndScore(flying, Eigen::Isometry3d::Identity(), truth, true, "sim flying", 0.0, &office), 0.0);
    report("sim office", "flying, unfiltered",
           mapAndScore(flying, Eigen::Isometry3d::Identity(), truth, false, "sim flying unfiltered", 0.0, &office), 0.0);
  }
  if (real) {
    const char* env = std::getenv("OSM_DATA_DIR");
    const std::string data = env && *env ? env : "../shared/data";
    const struct {
      const char* name;
      osm::tools::DepthIntrinsics intrinsics;
    } sequences[] = {{"tum_fr3_cabinet", osm::tools::DepthIntrinsics::tum()},  // TUM's documented conversion
                     {"tum_fr1_rpy", osm::tools::DepthIntrinsics::tum()}};
    for (const auto& s : sequences) {
      std::vector<Frame> frames;
      if (!realFrames(data + "/" + s.name, s.intrinsics, every, &frames)) continue;
      double reference_ms = 0.0;
      const osm::GridImage reference = octomapReference(frames, reference_min_z, 0.80, reference_range, &reference_ms);
      for (const Variant& v : variants()) report(s.name, v.name, mapAndScore(frames, v.world, reference, true, std::string(s.name) + " " + v.name), reference_ms);
      std::string error;
      if (!pictures.empty()) osm::savePng(reference, pictures + "/" + s.name + "_reference.png", &error);
    }
  }
  if (as_json) std::printf("{\"bench\": \"floor\", \"results\": [%s]}\n", json.c_str());
  return 0;
}
