// bench_cloud_insertion: depth-camera frames into the octree, against OctoMap's own
// methods, in one process.
//
//   bench_cloud_insertion [--frames N] [--rounds R] [--resolution M] [--ours-only] [--scene desk|room]
//                         [--no-floor] [--no-flying-filter] [--shared-free-run N] [--stages N]
//
// Frames come from the simulated Kinect-class camera (sim/depth_camera.h: 640 x 480, 57 x 43 deg,
// 0.5-4.5 m, the Kinect's depth noise) in the simulated office room, in two scenes: "desk" (the
// camera above the table, looking down at it: ranges 0.5-2 m) and "room" (from a corner across
// the room: up to 4.5 m). Each scene's frames (the camera moving 2 cm and turning 0.5 deg between
// them) go, in order, into a fresh 0.05 m octree per method:
//   ours: the node's path: PointCloud2 (organized, NaN where no depth) -> checked, converted to
//         the map frame with its flying pixels left out (toDeferredCloud, made) -> Mapper::insert (full inverse model, one ray per
//         end voxel, shared free space walked about once: cloud_shared_free_run 16);
//         "whole rays": the same with every ray walked whole (cloud_shared_free_run 0); "per
//         point": that with one ray per point too (cloud_one_ray_per_voxel false);
//   octomap insertPointCloud, and insertPointCloud(..., discretize = true) (one ray per end
//         voxel), given the frame's finite points already in the map frame.
//   ours, pipelined: the same frames through the node's CloudPipeline (two workers: frames
//         converted and prepared in parallel, applied in order; the layout checked on the
//         submitting thread, as the node does); ms per frame = wall time of all frames / frames
//         (throughput) of a pass into a fresh session. In each of R rounds (default 5) OctoMap's
//         two methods go frame by frame into fresh trees, every OctoMap frame timed beside a
//         pass of its own (the order turned every pair): a pair's ratio is the frame's time over
//         the pass's time per frame, and "pipe/oct" and "pipe/discr" are the median of all pairs'
//         ratios (2 R N passes). The last pass's octree must equal ours leaf for leaf.
// Prints per scene the median ms per frame and the ratios, how our map differs from the whole
// rays' and from the per-point one (voxels by class, the navigation slice's cells by map_server's
// class), and a JSON line (exit status 1 if a pipelined map differs). --ours-only: only ours, 20
// times, and the pipelined runs (for profiling). --no-floor, --no-flying-filter: the floor's and the
// flying-pixel filter's options off (floor_find, cloud_flying_pixel_filter), to see what they cost.
// --shared-free-run N: ours and pipelined with cloud_shared_free_run N (default the option's), the
// whole rays' comparison showing what it leaves unknown.
// --stages N: instead, the least of N runs of the conversion (without and with the flying-pixel
// filter) and of the end-voxel grouping of each scene's first frame, and each frame's least of
// N / 20 passes of the whole frame on one thread (conversion, preparing, applying).
#include <octomap/OcTree.h>
#include <sensor_msgs/PointCloud2.h>

#include <boost/make_shared.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/cloud_pipeline.h"
#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "core/internal/end_voxel_grouping.h"
#include "core/internal/memory_reuse.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/slice_grid.h"
#include "ros/point_cloud_conversion.h"

namespace osm = octo_slice_mapper;
using osm::bench::median;

namespace {

struct Frame {
  Eigen::Isometry3d optical_in_map;
  sensor_msgs::PointCloud2::ConstPtr msg;  // in the optical frame, organized
  octomap::Pointcloud points;    // its finite points in the map frame (for OctoMap's methods)
  std::size_t valid = 0;
};

std::vector<Frame> framesOf(const osm::sim::BoxScene& scene, const Eigen::Vector3d& start, double yaw, double pitch,
                            int count) {
  osm::sim::DepthCameraSpec spec;
  std::mt19937 rng(3);
  std::vector<Frame> frames;
  for (int k = 0; k < count; ++k) {
    Frame f;
    f.optical_in_map = osm::sim::opticalPose(start + Eigen::Vector3d(0.02 * k, 0.01 * k, 0.0), yaw + 0.0087 * k, pitch);
    const std::vector<Eigen::Vector3f> points = osm::sim::depthFrame(scene, f.optical_in_map, spec, &rng);
    f.msg = boost::make_shared<const sensor_msgs::PointCloud2>(
        osm::ros_adapter::organizedCloud(points, spec.width, spec.height, "camera_depth_optical_frame"));
    for (const Eigen::Vector3f& p : points) {
      if (!p.allFinite()) continue;
      const Eigen::Vector3d m = f.optical_in_map * p.cast<double>();
      f.points.push_back(m.x(), m.y(), m.z());
      ++f.valid;
    }
    frames.push_back(std::move(f));
  }
  return frames;
}

// Wall time of one call, ms.
template <typename Work>
double msOf(Work&& work) {
  const auto t0 = std::chrono::steady_clock::now();
  work();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Throughput of the frames through a CloudPipeline of `threads` workers into a fresh session: ms
// per frame (all frames' wall time / frames), and the session's octree afterwards in `tree`.
double pipelinedMsPerFrame(const std::vector<Frame>& frames, const osm::MapperOptions& options, unsigned threads,
                           std::unique_ptr<octomap::OcTree>* tree) {
  osm::MappingSession session(options, osm::SessionOptions{});
  const double ms = msOf([&] {  // the pipeline's start and drain included
    osm::CloudPipeline pipeline(&session, threads, 2 * threads);
    for (const Frame& f : frames) {
      // As the node: the layout checked on this thread, the points converted on the worker.
      osm::DeferredCloud cloud;
      const osm::ros_adapter::ScanRejection rejected = osm::ros_adapter::toDeferredCloud(f.msg, f.optical_in_map, &cloud);
      if (rejected.rejected()) std::fprintf(stderr, "rejected: %s\n", rejected.message.c_str());
      pipeline.submit(std::move(cloud), [](const osm::CloudPipeline::Outcome& o) {
        if (!o.result.ok()) std::fprintf(stderr, "refused: %s\n", o.result.error.c_str());
      });
    }
    pipeline.wait();
  });
  if (tree) {
    session.withMapper([&](osm::Mapper& m) {
      tree->reset(new octomap::OcTree(m.tree()));
    });
  }
  return ms / static_cast<double>(frames.size());
}

// A frame converted as the node converts it (toDeferredCloud, made on a pipeline's worker with
// the flying-pixel filter), so that "ours" and the pipelined runs see the same points.
void convert(const Frame& f, const osm::FlyingPixelOptions& flying, osm::SensorCloud* cloud) {
  osm::DeferredCloud deferred;
  const osm::ros_adapter::ScanRejection rejected = osm::ros_adapter::toDeferredCloud(f.msg, f.optical_in_map, &deferred);
  if (rejected.rejected()) std::fprintf(stderr, "rejected: %s\n", rejected.message.c_str());
  *cloud = deferred.made(flying);
}

// Whether two octrees have the same leaves (keys at the same depth) with the same log-odds.
bool sameLeaves(const octomap::OcTree& a, const octomap::OcTree& b) {
  if (a.getNumLeafNodes() != b.getNumLeafNodes()) return false;
  for (auto it = a.begin_leafs(); it != a.end_leafs(); ++it) {
    const octomap::OcTreeNode* n = b.search(it.getKey(), it.getDepth());
    if (!n || n->getLogOdds() != it->getLogOdds()) return false;
  }
  return true;
}

// How a map made with an approximation agrees with its reference: the reference's voxels by
// class in the other, and the navigation slices' cells by map_server's class.
struct Agreement {
  std::size_t same = 0, differ = 0, missing = 0, occupied = 0, occupied_lost = 0;
  std::size_t cells = 0, cells_same = 0, occupied_cells = 0, occupied_cells_kept = 0;
  double sameShare() const { return same / std::max(1.0, double(same + differ + missing)); }
  double occupiedLostShare() const { return occupied_lost / std::max(1.0, double(occupied)); }
  double sliceSameShare() const { return cells_same / std::max(1.0, double(cells)); }
};

// The reference's voxels by class in the other map, and the navigation slices' cells as map_server
// reads them (trinaryOf: 100 occupied, 0 free, -1 unknown), the other slice drawn in the
// reference's frame.
Agreement agreement(osm::Mapper& reference, osm::Mapper& other) {
  Agreement g;
  const octomap::OcTree& a = reference.tree();
  const octomap::OcTree& b = other.tree();
  for (auto it = a.begin_leafs(); it != a.end_leafs(); ++it) {
    const octomap::OcTreeNode* n = b.search(it.getKey());
    const bool occ = a.isNodeOccupied(*it);
    g.occupied += occ;
    if (!n) {
      ++g.missing;
      g.occupied_lost += occ;
    } else if (b.isNodeOccupied(n) == occ) {
      ++g.same;
    } else {
      ++g.differ;
      g.occupied_lost += occ;
    }
  }
  const osm::GridImage ref = osm::trinaryOf(osm::gridImageOf(reference.slice()));
  const osm::GridImage mine = osm::trinaryOf(osm::inFrameOf(osm::gridImageOf(other.slice()), ref));
  // inFrameOf keeps ref's lattice and covers its extent (grown where `other` knows more).
  const int di = static_cast<int>(std::lround((ref.origin_x - mine.origin_x) / ref.resolution));
  const int dj = static_cast<int>(std::lround((ref.origin_y - mine.origin_y) / ref.resolution));
  for (int j = 0; j < ref.height; ++j) {
    for (int i = 0; i < ref.width; ++i) {
      const int r = ref.at(i, j);
      if (r < 0) continue;
      const int v = mine.at(i + di, j + dj);
      ++g.cells;
      g.cells_same += v == r;
      if (r == 100) {
        ++g.occupied_cells;
        g.occupied_cells_kept += v == 100;
      }
    }
  }
  return g;
}

void printAgreement(const char* what, const char* reference, const Agreement& g) {
  const double leaves = std::max(1.0, double(g.same + g.differ + g.missing));
  std::printf("         %s: of the %s map's %zu voxels %.2f %% same class, %.2f %% other class, %.2f %% unknown; "
              "of its %zu occupied %.2f %% not occupied\n",
              what, reference, g.same + g.differ + g.missing, 100.0 * g.same / leaves, 100.0 * g.differ / leaves,
              100.0 * g.missing / leaves, g.occupied, 100.0 * g.occupiedLostShare());
  std::printf("           navigation slice (0.05-0.80 m): of its %zu known cells %.2f %% the same class, of its %zu "
              "occupied %.2f %% occupied\n",
              g.cells, 100.0 * g.sliceSameShare(), g.occupied_cells,
              100.0 * g.occupied_cells_kept / std::max(1.0, double(g.occupied_cells)));
}

template <typename Insert>
std::vector<double> timeFrames(const std::vector<Frame>& frames, Insert&& insert) {
  std::vector<double> ms;
  for (const Frame& f : frames) ms.push_back(msOf([&] { insert(f); }));
  return ms;
}

// --stages: the least of `runs` runs of the first stages of the scene's first frame, one thread:
// the conversion to the map frame without and with the flying-pixel filter, and the grouping of
// its points by end voxel (what the stages cost, without the pipeline's and the machine's noise).
void printStages(const char* name, const Frame& f, double resolution, int runs) {
  osm::FlyingPixelOptions off, on;
  off.enabled = false;
  std::vector<Eigen::Vector3f> points;
  double plain = 1e300, filtered = 1e300, grouping = 1e300;
  std::size_t voxels = 0;
  const unsigned depth = octomap::OcTree(resolution).getTreeDepth();
  for (int r = 0; r < runs; ++r) {
    osm::ReadingCounts counts;
    plain = std::min(plain, msOf([&] { osm::ros_adapter::cloudPointsInMap(*f.msg, f.optical_in_map.cast<float>(), &points,
                                                                         &counts, &off); }));
    filtered = std::min(filtered, msOf([&] { osm::ros_adapter::cloudPointsInMap(*f.msg, f.optical_in_map.cast<float>(),
                                                                              &points, &counts, &on); }));
    grouping = std::min(grouping, msOf([&] {
                          // (Offsets from the sensor, as the inserter sums them.)
                          voxels = osm::groupByEndVoxel(points, resolution, depth, 1,
                                                        f.optical_in_map.translation().cast<float>())
                                       .voxels.size();
                        }));
  }
  std::printf("  %-6s %8zu points %6zu end voxels: conversion %.3f ms, with the flying-pixel filter %.3f ms, "
              "grouping %.3f ms (least of %d)\n",
              name, points.size(), voxels, plain, filtered, grouping, runs);
}

// --stages: a whole frame on one thread, as a pipeline worker takes it (conversion, preparing
// with the grouping on one thread, applying), each frame's least of `runs` passes over the
// scene's frames into a fresh map; the mean over the frames after the first two (the first ones
// meet an empty map and no floor yet). Least-of-N per frame is steady to a few percent on a busy
// machine, where single runs are not.
void printFrames(const char* name, const std::vector<Frame>& frames, const osm::MapperOptions& options, int runs) {
  std::vector<double> least(frames.size(), 1e300);
  for (int r = 0; r < runs; ++r) {
    osm::Mapper mapper(options);
    const std::unique_ptr<osm::CloudPreparer> preparer = mapper.cloudPreparer();  // a worker's, kept
    preparer->setGroupingThreads(1);
    for (std::size_t k = 0; k < frames.size(); ++k) {
      least[k] = std::min(least[k], msOf([&] {
        osm::SensorCloud cloud;
        convert(frames[k], options.insert.cloud_flying_pixels, &cloud);
        osm::InsertResult result;
        mapper.insertPrepared(preparer->prepare(cloud), preparer->mapGeneration(), &result);
      }));
    }
  }
  const std::size_t skip = frames.size() > 2 ? 2 : 0;
  double sum = 0.0;
  for (std::size_t k = skip; k < frames.size(); ++k) sum += least[k];
  std::printf("  %-6s a whole frame on one thread: %.3f ms (mean of frames %zu-%zu, each the least of %d)\n", name,
              sum / double(frames.size() - skip), skip + 1, frames.size(), runs);
}

}  // namespace

int main(int argc, char** argv) {
  int frames_per_scene = 10;
  int rounds = 5;  // of OctoMap's methods frame by frame, each frame paired with a pipelined pass
  double resolution = 0.05;
  bool ours_only = false;  // for profiling
  std::string only_scene;  // "" = both
  bool find_floor = true, flying_filter = true;  // off: what the two cost (floor_find, cloud_flying_pixel_filter)
  int stage_runs = 0;  // --stages N: only the stages' least times
  int shared_free_run = -1;  // --shared-free-run N (-1: the option's default)
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--frames" && i + 1 < argc) frames_per_scene = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--resolution" && i + 1 < argc) resolution = std::atof(argv[++i]);
    else if (arg == "--ours-only") ours_only = true;
    else if (arg == "--scene" && i + 1 < argc) only_scene = argv[++i];
    else if (arg == "--rounds" && i + 1 < argc) rounds = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--no-floor") find_floor = false;
    else if (arg == "--no-flying-filter") flying_filter = false;
    else if (arg == "--stages" && i + 1 < argc) stage_runs = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--shared-free-run" && i + 1 < argc) shared_free_run = std::max(0, std::atoi(argv[++i]));
    else {
      std::fprintf(stderr,
                   "usage: bench_cloud_insertion [--frames N] [--rounds R] [--resolution M] [--ours-only] [--scene desk|room] "
                   "[--no-floor] [--no-flying-filter] [--shared-free-run N] [--stages N]\n");
      return 2;
    }
  }
  osm::keepFreedMemoryForReuse();  // as the node's process does (memory_reuse.h)
  const osm::sim::BoxScene scene = osm::sim::BoxScene::officeRoom();
  struct Scene {
    const char* name;
    std::vector<Frame> frames;
  };
  std::vector<Scene> scenes = {
      {"desk", framesOf(scene, Eigen::Vector3d(2.0, 1.8, 1.0), 0.0, 0.7, frames_per_scene)},
      {"room", framesOf(scene, Eigen::Vector3d(0.3, 0.3, 0.30), 0.7, 0.05, frames_per_scene)}};
  if (!only_scene.empty()) {
    scenes.erase(std::remove_if(scenes.begin(), scenes.end(), [&](const Scene& s) { return only_scene != s.name; }),
                 scenes.end());
  }
  osm::MapperOptions options;
  options.resolution = resolution;
  options.keep_scans = false;
  options.slice.min_z = osm::kNavigationBandMinZ;
  options.slice.max_z = osm::kNavigationBandMaxZ;
  options.floor.find = find_floor;
  options.insert.cloud_flying_pixels.enabled = flying_filter;
  if (shared_free_run >= 0) options.insert.cloud_shared_free_run = shared_free_run;
  if (stage_runs > 0) {
    std::printf("== the first stages of each scene's first frame, one thread\n");
    for (const Scene& sc : scenes) printStages(sc.name, sc.frames.front(), resolution, stage_runs);
    for (const Scene& sc : scenes) printFrames(sc.name, sc.frames, options, std::max(1, stage_runs / 20));
    return 0;
  }
  const int repeats = ours_only ? 20 : 1;
  std::printf("== depth frames, 640 x 480, %.2f m, %d frames per scene, %d rounds (median ms per frame; pipe/oct and "
              "pipe/discr: median of the ratios of OctoMap's frames to a pipelined pass timed beside each)\n",
              resolution, frames_per_scene, rounds);
  std::printf("  %-6s %8s %10s %10s %11s %10s %12s %12s %10s %10s %10s %10s\n", "scene", "points", "ours", "pipelined",
              "whole rays", "per point", "octomap", "discretized", "vs octomap", "vs discr.", "pipe/oct", "pipe/discr");
  std::string json = "{\"bench\": \"cloud_insertion\", \"resolution\": " + std::to_string(resolution) + ", \"scenes\": {";
  bool all_same = true;  // the pipelined maps equal ours
  for (std::size_t s = 0; s < scenes.size(); ++s) {
    const std::vector<Frame>& frames = scenes[s].frames;
    osm::Mapper mapper(options);
    osm::SensorCloud cloud;
    std::vector<double> ours, conversion_ms;
    for (int r = 0; r < repeats; ++r) {
      const std::vector<double> run = timeFrames(frames, [&](const Frame& f) {
      const auto t0 = std::chrono::steady_clock::now();
      convert(f, options.insert.cloud_flying_pixels, &cloud);
      const auto t1 = std::chrono::steady_clock::now();
      mapper.insert(cloud);
      conversion_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      });
      ours.insert(ours.end(), run.begin(), run.end());
    }
    // Frames in parallel on two workers, applied in order: throughput, and the map (equal to ours
    // when each frame went into a fresh map once, i.e. without --ours-only's repeats). Paired with
    // OctoMap's frames at a fine grain: each OctoMap frame (into that method's tree of the round)
    // is timed right beside a whole pipelined pass over the frames (into a fresh session), the
    // order turned every pair, and a ratio is that frame's time over the pass's time per frame.
    // The host's speed changes within a second (OctoMap's frames of one round 140 and
    // 220 ms apart), so a ratio of a 50 ms pass to 2 s of OctoMap's frames wandered by +-20 %.
    std::vector<double> pipelined, plain, discrete, pipe_vs_plain, pipe_vs_discrete;
    std::vector<double> round_vs_plain, round_vs_discrete;  // per round: median of its pairs
    std::unique_ptr<octomap::OcTree> pipelined_tree;
    const auto origin = [](const Frame& f) {
      const Eigen::Vector3d o = f.optical_in_map.translation();
      return octomap::point3d(o.x(), o.y(), o.z());
    };
    // One OctoMap frame and one pass beside it: the ratio of the frame's ms to the pass's per frame.
    // `tree`: where the pass's octree goes (the last pass's is checked; copying every one was
    // 100 octree copies per scene for nothing).
    const auto pair = [&](int turn, auto&& octomap_frame, std::vector<double>* octomap_ms,
                          std::unique_ptr<octomap::OcTree>* tree) {
      double frame_ms = 0.0, pass_ms = 0.0;
      if (turn % 2 == 1) frame_ms = msOf(octomap_frame);
      pass_ms = pipelinedMsPerFrame(frames, options, 2, tree);
      if (turn % 2 == 0) frame_ms = msOf(octomap_frame);
      pipelined.push_back(pass_ms);
      octomap_ms->push_back(frame_ms);
      return frame_ms / pass_ms;
    };
    for (int r = 0; r < rounds; ++r) {
      if (ours_only) {
        pipelined.push_back(pipelinedMsPerFrame(frames, options, 2, r + 1 == rounds ? &pipelined_tree : nullptr));
        continue;
      }
      octomap::OcTree full(resolution), discretized(resolution);
      std::vector<double> vs_plain, vs_discrete;
      for (std::size_t i = 0; i < frames.size(); ++i) {
        const Frame& f = frames[i];
        const int turn = r + static_cast<int>(i);
        const bool last = r + 1 == rounds && i + 1 == frames.size();
        vs_plain.push_back(pair(turn, [&] { full.insertPointCloud(f.points, origin(f)); }, &plain, nullptr));
        vs_discrete.push_back(pair(turn + 1, [&] { discretized.insertPointCloud(f.points, origin(f), -1.0, false, true); },
                                   &discrete, last ? &pipelined_tree : nullptr));
      }
      pipe_vs_plain.insert(pipe_vs_plain.end(), vs_plain.begin(), vs_plain.end());
      pipe_vs_discrete.insert(pipe_vs_discrete.end(), vs_discrete.begin(), vs_discrete.end());
      round_vs_plain.push_back(median(vs_plain));
      round_vs_discrete.push_back(median(vs_discrete));
    }
    bool pipelined_same = true;
    if (!ours_only) {
      pipelined_same = sameLeaves(mapper.tree(), *pipelined_tree) && sameLeaves(*pipelined_tree, mapper.tree());
      if (!pipelined_same) std::fprintf(stderr, "pipelined map differs from ours\n");
    }
    // The approximations' reference: every ray walked whole (cloud_shared_free_run 0), one
    // ray per end voxel ("whole rays") and one per point (cloud_one_ray_per_voxel false too).
    osm::MapperOptions whole_options = options;
    whole_options.insert.cloud_shared_free_run = 0;
    osm::Mapper whole(whole_options);
    const std::vector<double> walked = ours_only ? std::vector<double>{0.0} : timeFrames(frames, [&](const Frame& f) {
      convert(f, options.insert.cloud_flying_pixels, &cloud);
      whole.insert(cloud);
    });
    osm::MapperOptions per_point_options = whole_options;
    per_point_options.insert.cloud_one_ray_per_voxel = false;
    osm::Mapper per_point(per_point_options);
    const std::vector<double> each = ours_only ? std::vector<double>{0.0} : timeFrames(frames, [&](const Frame& f) {
      convert(f, options.insert.cloud_flying_pixels, &cloud);
      per_point.insert(cloud);
    });
    Agreement vs_per_point, vs_whole;
    if (!ours_only) {
      vs_per_point = agreement(per_point, mapper);
      vs_whole = agreement(whole, mapper);
    }
    if (ours_only) plain = discrete = pipe_vs_plain = pipe_vs_discrete = {0.0};
    if (ours_only) std::printf("  (%s: conversion from PointCloud2 %.2f ms of it)\n", scenes[s].name, median(conversion_ms));
    std::vector<double> valid;
    for (const Frame& f : frames) valid.push_back(static_cast<double>(f.valid));
    const double o = median(ours), p = median(plain), d = median(discrete), e = median(each), q = median(pipelined),
                 w = median(walked);
    const double pq = median(pipe_vs_plain), dq = median(pipe_vs_discrete);
    std::printf("  %-6s %8.0f %10.1f %10.1f %11.1f %10.1f %12.1f %12.1f %9.2fx %9.2fx %9.2fx %9.2fx\n",
                scenes[s].name, median(valid), o, q, w, e, p, d, p / o, d / o, pq, dq);
    if (!ours_only) {
      std::string per_round;
      for (std::size_t r = 0; r < round_vs_plain.size(); ++r) {
        char one[64];
        std::snprintf(one, sizeof one, "%s%.1fx / %.2fx", r ? ", " : "", round_vs_plain[r], round_vs_discrete[r]);
        per_round += one;
      }
      std::printf("         pipelined vs octomap / vs discretized, median of each round's pairs: %s\n", per_round.c_str());
      printAgreement("shared free space vs whole rays", "whole-ray", vs_whole);
      printAgreement("ours vs one ray per point, walked whole", "per-point", vs_per_point);
    }
    char part[800];
    std::snprintf(part, sizeof part,
                  "%s\"%s\": {\"points\": %.0f, \"ours_ms\": %.2f, \"whole_rays_ms\": %.2f, \"ours_per_point_ms\": %.2f, "
                  "\"octomap_ms\": %.2f, \"discretized_ms\": %.2f, \"same_class\": %.4f, \"occupied_lost\": %.4f, "
                  "\"same_class_vs_whole_rays\": %.4f, \"slice_same_vs_whole_rays\": %.4f, \"pipelined_ms\": %.2f, "
                  "\"pipelined_same_map\": %s, \"pipelined_vs_octomap\": %.2f, \"pipelined_vs_discretized\": %.2f}",
                  s ? ", " : "", scenes[s].name, median(valid), o, w, e, p, d, vs_per_point.sameShare(),
                  vs_per_point.occupiedLostShare(), vs_whole.sameShare(), vs_whole.sliceSameShare(), q,
                  pipelined_same ? "true" : "false", pq, dq);
    json += part;
    all_same = all_same && pipelined_same;
  }
  std::printf("%s}}\n", json.c_str());
  return all_same ? 0 : 1;
}
