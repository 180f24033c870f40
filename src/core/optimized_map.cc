#include "octo_slice_mapper/optimized_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "octo_slice_mapper/internal/key_box.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/internal/octree_batch_update.h"

namespace octo_slice_mapper {

OptimizedMap optimizeScans(const std::vector<StoredScan>& scans, const GlobalOptimizerOptions& options,
                           double resolution, const GridImage* warm_start, const ProgressFn& progress,
                           const RevisitFrom* revisit, std::unique_ptr<GlobalOptimizer>* kept,
                           const std::atomic<bool>* stop) {
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<GlobalOptimizer> own;
  std::unique_ptr<GlobalOptimizer>& held = kept ? *kept : own;
  const bool extended = revisit && revisit->earlier && held && held->extend(scans, revisit->first_new_scan);
  if (!extended) {
    held = std::make_unique<GlobalOptimizer>(options, resolution);
    held->build(scans, progress);
  }
  GlobalOptimizer& optimizer = *held;
  optimizer.stopWhen(stop);
  if (warm_start) optimizer.startFrom(*warm_start);
  else if (extended) optimizer.startEmpty();  // the new beams' records are set by a start
  const double build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  OptimizedMap out;
  if (revisit && revisit->earlier) {
    const std::vector<std::uint8_t> look = optimizer.cellsToRevisit(revisit->first_new_scan, *revisit->earlier);
    out.report = optimizer.optimize(progress, &look);
  } else {
    out.report = optimizer.optimize(progress);
  }
  out.report.build_seconds = build_seconds;
  out.report.index_extended = extended;
  out.grid = cropToKnown(optimizer.result());
  out.state = cropToKnown(optimizer.state());
  return out;
}

PassBand PassBand::of(const std::vector<StoredScan>& scans, const octomap::OcTree& tree, unsigned band_lo,
                      unsigned band_hi) {
  PassBand band;
  band.band_lo = band_lo;
  band.band_hi = band_hi;
  bool any = false;
  for (const StoredScan& s : scans) {
    // The heights its beams sweep: a level scan stays in its origin's layer; one tilted by a degree
    // reaches +-0.2 m at 12 m (far returns of a real robot's lidar land in the layers beside).
    const Eigen::Matrix3f r = s.rotation.toRotationMatrix();
    const double reach = std::min<double>(s.range_max, 100.0) * std::hypot(r(2, 0), r(2, 1));
    octomap::OcTreeKey low, high;
    if (!coordToKeySafe(tree, s.origin.x(), s.origin.y(), s.origin.z() - reach, &low) ||
        !coordToKeySafe(tree, s.origin.x(), s.origin.y(), s.origin.z() + reach, &high)) {
      continue;
    }
    band.scans_lo = any ? std::min<unsigned>(band.scans_lo, low[2]) : low[2];
    band.scans_hi = any ? std::max<unsigned>(band.scans_hi, high[2]) : high[2];
    any = true;
  }
  return band;
}

std::vector<octomap::OcTreeKey> obstaclesBesidePass(const octomap::OcTree& tree, const PassBand& band,
                                                    const GridImage* within) {
  std::vector<octomap::OcTreeKey> keys;
  if (band.scans_lo > band.scans_hi) return keys;
  const unsigned depth = tree.getTreeDepth();
  // The band's leaves only (a slab of the tree, or of the grid's columns): a lidar-only map has
  // none beside the pass's layers, and this costs it a walk down to them.
  octomap::OcTreeKey lo(0, 0, static_cast<octomap::key_type>(band.band_lo));
  octomap::OcTreeKey hi(0xFFFF, 0xFFFF, static_cast<octomap::key_type>(band.band_hi));
  if (within) {
    const double x1 = within->origin_x + within->width * within->resolution;
    const double y1 = within->origin_y + within->height * within->resolution;
    octomap::OcTreeKey a, b;
    if (!coordToKeySafe(tree, within->origin_x, within->origin_y, 0.0, &a) || !coordToKeySafe(tree, x1, y1, 0.0, &b)) {
      return obstaclesBesidePass(tree, band, nullptr);
    }
    lo[0] = a[0], lo[1] = a[1], hi[0] = b[0], hi[1] = b[1];
  }
  for (auto it = tree.begin_leafs_bbx(lo, hi), end = tree.end_leafs_bbx(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    // A pruned leaf spans a cube of voxels: those of it in the band and beside the pass.
    const unsigned span = 1u << (depth - it.getDepth());
    const octomap::OcTreeKey k = it.getKey();
    const unsigned base[3] = {k[0] & ~(span - 1), k[1] & ~(span - 1), k[2] & ~(span - 1)};
    for (unsigned kz = std::max(base[2], band.band_lo); kz <= std::min(base[2] + span - 1, band.band_hi); ++kz) {
      if (band.passSpeaksFor(kz)) continue;
      for (unsigned ky = base[1]; ky < base[1] + span; ++ky) {
        for (unsigned kx = base[0]; kx < base[0] + span; ++kx) keys.emplace_back(kx, ky, kz);
      }
    }
  }
  return keys;
}

GridImage withObstacles(const GridImage& grid, const GridImage& frame, const std::vector<std::size_t>& cells) {
  GridImage out = grid;
  for (std::size_t c : cells) {
    const int fi = int(c % std::size_t(frame.width)), fj = int(c / std::size_t(frame.width));
    const int i = fi + int(std::lround((frame.origin_x - grid.origin_x) / grid.resolution));
    const int j = fj + int(std::lround((frame.origin_y - grid.origin_y) / grid.resolution));
    if (i >= 0 && j >= 0 && i < out.width && j < out.height) out.cells[std::size_t(j) * out.width + i] = 100;
  }
  return out;
}

std::vector<octomap::OcTreeKey> writeGridIntoBand(const GridImage& grid, const PassBand& band, octomap::OcTree* tree) {
  std::vector<KeyUpdate> values;
  const float occupied = tree->getClampingThresMaxLog(), free = tree->getClampingThresMinLog();
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const int v = grid.at(i, j);
      if (v < 0) continue;
      octomap::OcTreeKey key;
      if (!coordToKeySafe(*tree, grid.origin_x + (i + 0.5) * grid.resolution,
                          grid.origin_y + (j + 0.5) * grid.resolution, 0.0, &key)) {
        continue;
      }
      for (unsigned kz = band.band_lo; kz <= band.band_hi; ++kz) {
        if (!band.passSpeaksFor(kz)) continue;  // another sensor's layer: its own evidence stays
        key[2] = static_cast<octomap::key_type>(kz);
        values.push_back({key, v > 50 ? occupied : free});
      }
    }
  }
  std::vector<octomap::OcTreeKey> written;
  written.reserve(values.size());
  for (const KeyUpdate& u : values) written.push_back(u.key);
  // One pass down the tree in octree order, pruning along the way: cost grows with the grid, not
  // with the whole tree (the node does this under its map lock).
  setValuesInTreeOrder(tree, &values);
  return written;
}

GridImage exportedOptimized(const octomap::OcTree& tree, const PassBand& band, const GridImage& grid,
                            const GridImage& incremental) {
  GridImage framed = inFrameOf(grid, incremental);
  for (const octomap::OcTreeKey& k : obstaclesBesidePass(tree, band)) {
    const int i = int(std::floor((tree.keyToCoord(k[0]) - framed.origin_x) / framed.resolution));
    const int j = int(std::floor((tree.keyToCoord(k[1]) - framed.origin_y) / framed.resolution));
    if (i >= 0 && j >= 0 && i < framed.width && j < framed.height) framed.cells[std::size_t(j) * framed.width + i] = 100;
  }
  return framed;
}

bool saveBestMapSet(const octomap::OcTree& tree, const PassBand& band, const GridImage* optimized,
                    const GridImage& incremental, const std::string& prefix, std::vector<std::string>* written,
                    std::string* error, const HeightMap* heights) {
  if (!optimized) return saveMapSet(tree, incremental, prefix, written, error, &incremental, heights);
  octomap::OcTree copy(tree);
  writeGridIntoBand(*optimized, band, &copy);
  return saveMapSet(copy, exportedOptimized(tree, band, *optimized, incremental), prefix, written, error, &incremental,
                    heights);
}

}  // namespace octo_slice_mapper
