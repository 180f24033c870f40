// The global pass applied to a map: run it over the kept scans, carry its result into the octree
// (so .bt export holds it) and save it beside the incremental map.
#pragma once

#include <octomap/OcTree.h>

#include <memory>
#include <string>
#include <vector>

#include "octo_slice_mapper/global_optimizer.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/internal/scan_store.h"

namespace octo_slice_mapper {

struct OptimizedMap {
  OptimizeReport report;
  GridImage grid;  // 100 occupied, 0 free, -1 never observed
  // The pass's own state: 100 occupied, 0 every other cell a beam reaches (also those behind a
  // wall that `grid` leaves unknown), -1 the rest. The start of a next pass over more scans: a
  // cell the pass freed stays free instead of coming back from the incremental map.
  GridImage state;
};

// When the start is a converged earlier result over scans[0, first_new_scan) (`earlier`), the
// first sweep need only look at the cells GlobalOptimizer::cellsToRevisit names.
struct RevisitFrom {
  std::size_t first_new_scan = 0;
  const GridImage* earlier = nullptr;
};

// Hill climbing over the cells the scans observed, from all-free (the lab's start) or, when
// `warm_start` is given, from its cells above 50 % (the incremental map's max-likelihood state);
// with `revisit`, the first sweep restricted as RevisitFrom says. With `kept` (the background
// pass), the optimizer is left there for the next call, and a call with `revisit` extends the beam
// index found there by the new scans where it can (GlobalOptimizer::extend: the same index as a
// build of all) instead of building it anew; report.index_extended says which it did. `stop`:
// see GlobalOptimizer::stopWhen.
OptimizedMap optimizeScans(const std::vector<StoredScan>& scans, const GlobalOptimizerOptions& options,
                           double resolution, const GridImage* warm_start = nullptr,
                           const ProgressFn& progress = {}, const RevisitFrom* revisit = nullptr,
                           std::unique_ptr<GlobalOptimizer>* kept = nullptr,
                           const std::atomic<bool>* stop = nullptr);

// The slice band's voxel layers (z keys band_lo..band_hi, SliceGrid::bandMinKey/MaxKey) and, of
// them, the layers the global pass speaks for: those its scans' beams sweep (a level 2D lidar's
// one; a tilted one's a few more). An obstacle in a band voxel outside those (a depth camera's table top or shelf overhang
// above the lidar's plane) is another sensor's evidence, which the pass cannot see: its result
// neither overwrites that voxel nor hides it (else a save with the global pass would erase the
// table top the camera mapped).
struct PassBand {
  unsigned band_lo = 0, band_hi = 0;
  unsigned scans_lo = 1, scans_hi = 0;  // the layers its beams sweep; none: the whole band
  static PassBand of(const std::vector<StoredScan>& scans, const octomap::OcTree& tree, unsigned band_lo,
                     unsigned band_hi);
  bool passSpeaksFor(unsigned kz) const { return scans_lo > scans_hi || (kz >= scans_lo && kz <= scans_hi); }
};

// The occupied band voxels in layers the pass does not speak for (in the columns of `within` if
// given), in the tree's leaf order.
std::vector<octomap::OcTreeKey> obstaclesBesidePass(const octomap::OcTree& tree, const PassBand& band,
                                                    const GridImage* within = nullptr);

// `grid` with the cells `cells` (indices into `frame`, a grid on the same lattice) occupied.
GridImage withObstacles(const GridImage& grid, const GridImage& frame, const std::vector<std::size_t>& cells);

// Sets the voxels of the band's layers the pass speaks for under every known cell of `grid` to the
// tree's clamping bound (occupied -> max, free -> min); unknown cells and the other layers are left
// alone: a level lidar's result does not stand for the whole band, and a later pass can tell its
// predecessor's walls from a camera's table top.
// `grid` must be aligned with the tree's voxel columns (GlobalOptimizer and SliceGrid grids are).
// Returns the keys written.
std::vector<octomap::OcTreeKey> writeGridIntoBand(const GridImage& grid, const PassBand& band, octomap::OcTree* tree);

// The global pass's result as a save exports it: `grid` with the obstacles beside the pass
// occupied, drawn in the frame of `incremental` (the incremental map saved beside it), so that
// the two overlay cell for cell.
GridImage exportedOptimized(const octomap::OcTree& tree, const PassBand& band, const GridImage& grid,
                            const GridImage& incremental);

// Writes the map set of a save (saveMapSet): with a global pass's `optimized` grid, PREFIX.* hold
// it (the .bt and .ot a copy of `tree` with the grid written into its band, the live tree
// unchanged; the 2D files exportedOptimized); without, the incremental map. PREFIX_incremental.*
// hold `incremental` either way; `heights`, when given, PREFIX_heights.*.
bool saveBestMapSet(const octomap::OcTree& tree, const PassBand& band, const GridImage* optimized,
                    const GridImage& incremental, const std::string& prefix, std::vector<std::string>* written,
                    std::string* error, const HeightMap* heights = nullptr);

}  // namespace octo_slice_mapper
