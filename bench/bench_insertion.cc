// bench_insertion: time per scan of this project's insertion (full inverse sensor model, into an
// OcTree) against OctoMap's own OcTree::insertPointCloud on the same scans, in the same process.
//
//   bench_insertion [--repeats N] [--resolution M]
//
// Scans: the simulated session (682 beams, 5.6 m). insertPointCloud gets the returns only (it has
// no notion of no-return readings, which we trace 4 m to clear space); "ours returns only" turns
// that clearing off so both do the same rays. Each repetition
// maps all scans into a fresh tree with each method in turn; medians over repetitions are printed.
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

using Clock = std::chrono::steady_clock;
namespace osm = octo_slice_mapper;

using octo_slice_mapper::bench::CloudScan;
using octo_slice_mapper::bench::median;

int main(int argc, char** argv) {
  int repeats = 5;
  double resolution = 0.05;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    if (arg == "--repeats") repeats = std::max(1, std::stoi(argv[i + 1]));
    else if (arg == "--resolution") resolution = std::stod(argv[i + 1]);
  }
  const osm::sim::SimulatedSession session(osm::sim::FloorPlan::office(), osm::sim::SessionSpec::officeTour());
  const std::vector<osm::Scan> scans = session.allScans();
  const std::vector<CloudScan> clouds = osm::bench::returnsAsClouds(scans);
  std::vector<double> ours_tree, ours_returns_only, ours_with_slice, octomap_cloud;
  osm::InsertOptions returns_only;
  returns_only.model.no_return_clear_distance = 0.0;  // the same work insertPointCloud is given
  std::fprintf(stderr, "bench_insertion: %zu scans x %zu beams, resolution %.3f m, %d repeats\n", scans.size(),
               scans.front().ranges.size(), resolution, repeats);
  for (int r = 0; r < repeats; ++r) {
    {
      octomap::OcTree tree(resolution);
      osm::ScanInserter inserter(&tree, osm::InsertOptions{});
      const auto t0 = Clock::now();
      for (const osm::Scan& s : scans) inserter.insert(s);
      inserter.flush();  // the octree brought up to date is part of the cost
      ours_tree.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / scans.size());
    }
    {
      octomap::OcTree tree(resolution);
      osm::ScanInserter inserter(&tree, returns_only);
      const auto t0 = Clock::now();
      for (const osm::Scan& s : scans) inserter.insert(s);
      inserter.flush();
      ours_returns_only.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / scans.size());
    }
    {
      // The node's whole per-scan work: insertion, slice refresh, and the copy kept for the global pass.
      osm::MapperOptions options;
      options.resolution = resolution;
      osm::Mapper mapper(options);
      const auto t0 = Clock::now();
      for (const osm::Scan& s : scans) mapper.insert(s);
      mapper.tree();  // flushes the insertion cache
      ours_with_slice.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / scans.size());
    }
    {
      octomap::OcTree tree(resolution);
      const auto t0 = Clock::now();
      for (const CloudScan& c : clouds) tree.insertPointCloud(c.points, c.origin);
      octomap_cloud.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / scans.size());
    }
    std::fprintf(stderr, "  repeat %d/%d: ours %.3f ms, ours returns only %.3f ms, ours+slice %.3f ms, insertPointCloud %.3f ms\n",
                 r + 1, repeats, ours_tree.back(), ours_returns_only.back(), ours_with_slice.back(), octomap_cloud.back());
  }
  const double a = median(ours_tree), ro = median(ours_returns_only), b = median(ours_with_slice),
               c = median(octomap_cloud);
  std::printf("{\"bench\": \"insertion\", \"scans\": %zu, \"resolution\": %.3f, \"repeats\": %d, "
              "\"ours_ms_per_scan\": %.3f, \"ours_returns_only_ms_per_scan\": %.3f, "
              "\"ours_with_slice_ms_per_scan\": %.3f, \"insertPointCloud_ms_per_scan\": %.3f, "
              "\"speedup_vs_insertPointCloud\": %.2f, \"speedup_returns_only_vs_insertPointCloud\": %.2f, "
              "\"speedup_with_slice_vs_insertPointCloud\": %.2f}\n",
              scans.size(), resolution, repeats, a, ro, b, c, c / a, c / ro, c / b);
  return 0;
}
