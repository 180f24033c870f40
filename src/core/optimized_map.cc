#include "octo_slice_mapper/optimized_map.h"

#include <chrono>

#include "octo_slice_mapper/key_box.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/octree_batch_update.h"

namespace octo_slice_mapper {

OptimizedMap optimizeScans(const std::vector<StoredScan>& scans, const GlobalOptimizerOptions& options,
                           double resolution, const GridImage* warm_start, const ProgressFn& progress,
                           const RevisitFrom* revisit, std::unique_ptr<GlobalOptimizer>* kept) {
  const auto t0 = std::chrono::steady_clock::now();
  std::unique_ptr<GlobalOptimizer> own;
  std::unique_ptr<GlobalOptimizer>& held = kept ? *kept : own;
  const bool extended = revisit && revisit->earlier && held && held->extend(scans, revisit->first_new_scan);
  if (!extended) {
    held = std::make_unique<GlobalOptimizer>(options, resolution);
    held->build(scans, progress);
  }
  GlobalOptimizer& optimizer = *held;
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
  return out;
}

std::vector<octomap::OcTreeKey> writeGridIntoBand(const GridImage& grid, unsigned band_lo, unsigned band_hi,
                                                  octomap::OcTree* tree) {
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
      for (unsigned kz = band_lo; kz <= band_hi; ++kz) {
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

bool saveOptimizedSet(const octomap::OcTree& tree, unsigned band_lo, unsigned band_hi, const GridImage& grid,
                      const GridImage& incremental, const std::string& prefix, std::vector<std::string>* written,
                      std::string* error) {
  octomap::OcTree copy(tree);
  writeGridIntoBand(grid, band_lo, band_hi, &copy);
  const std::string base = prefix + "_optimized";
  const GridImage framed = inFrameOf(grid, incremental);
  FileSet files;
  return addBinaryTree(copy, base + ".bt", &files, error) && addPgmYaml(framed, base, &files, error) &&
         addPng(framed, base + ".png", &files, error) && writeFilesAtomically(files, written, error);
}

}  // namespace octo_slice_mapper
