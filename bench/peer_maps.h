// The two maps this project's must beat, built from the same scans:
//   - octomap_server's method: per scan, free / occupied KeySets from computeRayKeys (occupied
//     wins), updateNode with hit 0.7 / miss 0.4, clamping 0.12 / 0.97; its projected 2D map
//     (a band column is occupied if any of its voxels is, else free if any is known);
//   - a dense hit/miss grid: per cell, hits / (hits + passes) of the returns' rays (a cell walk
//     from the laser's cell to the return's cell, the return's cell a hit), as a percentage, or
//     with `max_likelihood` as occupied (hits >= passes) / free.
// Both take the returns only (readings classified kHit), as those methods do.
#pragma once

#include <octomap/OcTree.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace bench {

inline GridImage octomapServerMap(const std::vector<Scan>& scans, double resolution, double min_z, double max_z) {
  octomap::OcTree tree(resolution);
  tree.setProbHit(0.7);
  tree.setProbMiss(0.4);
  tree.setClampingThresMin(0.12);
  tree.setClampingThresMax(0.97);
  for (const CloudScan& scan : returnsAsClouds(scans)) insertLikeOctomapServer(&tree, scan);
  std::unordered_map<std::uint32_t, std::int8_t> columns;  // key x << 16 | key y
  int x0 = 1 << 16, y0 = 1 << 16, x1 = -1, y1 = -1;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (it.getZ() < min_z || it.getZ() > max_z) continue;
    const octomap::OcTreeKey k = it.getKey();
    const unsigned span = 1u << (tree.getTreeDepth() - it.getDepth());
    const unsigned mask = ~(span - 1);
    const std::int8_t v = tree.isNodeOccupied(*it) ? 100 : 0;
    for (unsigned dx = 0; dx < span; ++dx) {
      for (unsigned dy = 0; dy < span; ++dy) {
        const int kx = int(k[0] & mask) + int(dx), ky = int(k[1] & mask) + int(dy);
        std::int8_t& c = columns.emplace((std::uint32_t(kx) << 16) | std::uint32_t(ky), v).first->second;
        c = std::max(c, v);
        x0 = std::min(x0, kx), y0 = std::min(y0, ky), x1 = std::max(x1, kx), y1 = std::max(y1, ky);
      }
    }
  }
  GridImage grid;
  grid.resolution = resolution;
  if (x1 < 0) return grid;
  grid.width = x1 - x0 + 1;
  grid.height = y1 - y0 + 1;
  grid.origin_x = tree.keyToCoord(octomap::key_type(x0)) - 0.5 * resolution;
  grid.origin_y = tree.keyToCoord(octomap::key_type(y0)) - 0.5 * resolution;
  grid.cells.assign(std::size_t(grid.width) * grid.height, -1);
  for (const auto& [xy, v] : columns) {
    grid.cells[std::size_t(int(xy & 0xFFFF) - y0) * grid.width + (int(xy >> 16) - x0)] = v;
  }
  return cropToKnown(grid);
}

inline GridImage hitMissGrid(const std::vector<Scan>& scans, double resolution, bool max_likelihood) {
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cells;  // hits, passes
  auto cell = [resolution](double v) { return static_cast<std::int64_t>(std::floor(v / resolution)); };
  auto id = [](std::int64_t i, std::int64_t j) { return (std::uint64_t(i + (1 << 30)) << 32) | std::uint64_t(j + (1 << 30)); };
  std::int64_t i0 = INT64_MAX, j0 = INT64_MAX, i1 = INT64_MIN, j1 = INT64_MIN;
  for (const CloudScan& scan : returnsAsClouds(scans)) {
    const double ox = scan.origin.x() / resolution, oy = scan.origin.y() / resolution;
    for (const octomap::point3d& p : scan.points) {
      std::int64_t i = cell(scan.origin.x()), j = cell(scan.origin.y());
      const std::int64_t ei = cell(p.x()), ej = cell(p.y());
      const double dx = p.x() / resolution - ox, dy = p.y() / resolution - oy;
      const int si = dx > 0 ? 1 : -1, sj = dy > 0 ? 1 : -1;
      const double inf = std::numeric_limits<double>::infinity();
      double ti = dx != 0 ? ((dx > 0 ? i + 1 : i) - ox) / dx : inf, tj = dy != 0 ? ((dy > 0 ? j + 1 : j) - oy) / dy : inf;
      const double di = dx != 0 ? 1.0 / std::abs(dx) : inf, dj = dy != 0 ? 1.0 / std::abs(dy) : inf;
      for (int steps = std::abs(int(ei - i)) + std::abs(int(ej - j)); steps > 0; --steps) {
        cells[id(i, j)].second++;
        if (ti < tj) i += si, ti += di;
        else j += sj, tj += dj;
      }
      cells[id(ei, ej)].first++;
      i0 = std::min(i0, ei), j0 = std::min(j0, ej), i1 = std::max(i1, ei), j1 = std::max(j1, ej);
      i0 = std::min(i0, cell(scan.origin.x())), j0 = std::min(j0, cell(scan.origin.y()));
      i1 = std::max(i1, cell(scan.origin.x())), j1 = std::max(j1, cell(scan.origin.y()));
    }
  }
  GridImage grid;
  grid.resolution = resolution;
  if (i1 < i0) return grid;
  grid.width = int(i1 - i0 + 1);
  grid.height = int(j1 - j0 + 1);
  grid.origin_x = i0 * resolution;
  grid.origin_y = j0 * resolution;
  grid.cells.assign(std::size_t(grid.width) * grid.height, -1);
  for (const auto& [key, hp] : cells) {
    const std::int64_t i = std::int64_t(key >> 32) - (1 << 30), j = std::int64_t(key & 0xFFFFFFFFu) - (1 << 30);
    if (i < i0 || j < j0 || i > i1 || j > j1) continue;
    const double ratio = hp.first / double(hp.first + hp.second);
    grid.cells[std::size_t(j - j0) * grid.width + std::size_t(i - i0)] =
        max_likelihood ? (ratio >= 0.5 ? 100 : 0) : static_cast<std::int8_t>(std::lround(100.0 * ratio));
  }
  return cropToKnown(grid);
}

}  // namespace bench
}  // namespace octo_slice_mapper
