// A 2D occupancy grid cut from the octree over a z band, kept up to date incrementally.
#pragma once

#include <octomap/OcTree.h>

#include <array>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "octo_slice_mapper/internal/key_box.h"
#include "octo_slice_mapper/internal/layer_cache.h"

namespace octo_slice_mapper {

struct SliceOptions {
  // The z band (map frame, m) whose voxels are projected. Default: the voxel layers within
  // +-0.10 m of the 0.26 m laser mount height.
  double min_z = 0.16;
  double max_z = 0.36;
  // rebuild() (loading a map) refuses a slice of more cells than this, with a reason: 10^8 cells
  // are 100 MB, 500 m x 500 m at 0.05 m.
  std::size_t max_cells = 100000000;
};

// The navigation band (m above the floor): from a margin over the floor to above the robot (a
// TurtleBot 2 with its camera), so that a table top and a shelf's overhang are in it. A depth
// camera's slice defaults to it (octo_slice_map --cloud-topic; mapper.launch.xml repeats it, as
// XML cannot read this), and the simulator's navigation truth is sliced from it.
constexpr double kNavigationBandMinZ = 0.05;
constexpr double kNavigationBandMaxZ = 0.80;

constexpr std::int8_t kUnknownCell = -1;
// A cell waiting to be recomputed while updateColumns() or rebuild() runs: no value a cell holds.
constexpr std::int8_t kPendingCell = 127;

// Cell (i, j) covers the octree column with keys (origin_key_x + i, origin_key_y + j). Values are
// the band's occupancy probability in percent (0..100) or -1 when no voxel of the band is known.
// Of several known voxels in a column the most occupied one counts when it is 50 % or more: an
// obstacle anywhere in the band blocks the robot. Else the least occupied one counts: the layer a
// beam crossed, not one it grazed with its cone's edge (a tilted scan's).
class SliceGrid {
 public:
  // With a `cache`, voxels of its layers are read from it (the tree may lag behind it).
  SliceGrid(const octomap::OcTree& tree, const SliceOptions& options, const LayerCache* cache = nullptr);

  // Recomputes the columns inside `box` (x/y of the keys; the band decides z). Cost is
  // proportional to the box area, independent of the map size.
  // Every change to the octree's band must reach the slice through update(), updateColumns() or
  // rebuild(): the slice skips band layers that none of them has seen.
  void update(const KeyBox& box);
  // Recomputes only the columns of `keys` that lie in the band (what one scan changed); cost is
  // proportional to the number of keys. With `changes` (one per key: its voxel's value before and
  // after), a column follows most of them from its own cell alone (columnAfter).
  void updateColumns(const std::vector<octomap::OcTreeKey>& keys, const KeyBox& box,
                     const std::vector<VoxelChange>& changes = {});
  // A column's value after one of its voxels changed, from its value before, when that alone
  // tells; else kPendingCell (the column must be read).
  static std::int8_t columnAfter(std::int8_t value, const VoxelChange& change);
  // Recomputes everything from the tree (after loading a map or for checking); its cost follows
  // the band's leaves. Throws std::length_error if the slice would pass options().max_cells.
  void rebuild();
  void clear();
  // Columns whose band lies whole voxels above or below the grid's band (the floor under them
  // is that many voxel layers off the floor the band was set for, floor_layer.h): per column
  // (key x | key y << 16) its shift, 0 for none. The listed columns are recomputed. A column's
  // shift stays until changed, also through rebuild() and clear().
  void shiftColumns(const std::vector<std::pair<std::uint32_t, int>>& shifts);
  int columnShift(std::uint16_t kx, std::uint16_t ky) const;

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_; }
  // World coordinates of the lower-left corner of cell (0, 0).
  double originX() const;
  double originY() const;
  const std::vector<std::int8_t>& data() const { return data_; }  // row-major, row = y
  std::int8_t at(int i, int j) const { return data_[std::size_t(j) * width_ + i]; }
  // Cell value at a world point, or -1 outside the grid.
  std::int8_t valueAt(double x, double y) const;
  bool cellOf(double x, double y, int* i, int* j) const;
  std::uint16_t originKeyX() const { return origin_key_x_; }
  std::uint16_t originKeyY() const { return origin_key_y_; }
  std::uint16_t bandMinKey() const { return band_lo_; }
  std::uint16_t bandMaxKey() const { return band_hi_; }
  const SliceOptions& options() const { return options_; }
  // Changes whenever the grid's size or origin changes, and differs between grids (a consumer of
  // incremental updates must then take the whole grid again).
  std::uint64_t geometry() const { return geometry_; }
  // Number of cells that are not unknown.
  std::size_t knownCells() const;
  // Bytes of the grid, including the unknown margin it keeps to grow into.
  std::size_t memoryBytes() const {
    return (data_.capacity() + shift_grid_.capacity()) * sizeof(std::int8_t) + sizeof(*this);
  }

 private:
  void ensureCovers(std::uint16_t kx0, std::uint16_t ky0, std::uint16_t kx1, std::uint16_t ky1);
  // Reads band_layers_, which findBandLayers() sets before each batch of columns.
  std::int8_t columnValue(std::uint16_t kx, std::uint16_t ky) const;
  // A shifted column's value, columnValue's rule over its own band (the cache's layers, else the tree).
  std::int8_t shiftedColumnValue(std::uint16_t kx, std::uint16_t ky, int shift) const;
  // Whether z keys [lo, hi] meet some column's band.
  bool meetsBands(unsigned lo, unsigned hi) const {
    return int(hi) >= int(band_lo_) + shift_min_ && int(lo) <= int(band_hi_) + shift_max_;
  }
  void findBandLayers();
  // The voxel (kx, ky, kz) below `top`, the node at `top_depth` holding it.
  const octomap::OcTreeNode* bandVoxel(const octomap::OcTreeNode* top, std::uint16_t kx, std::uint16_t ky, unsigned kz,
                                       unsigned top_depth) const;
  class ColumnDescent;

  // Recomputes the columns of `box` (x/y) from the layers noted so far.
  void recompute(const KeyBox& box);
  // Marks the band layers kz0..kz1 as possibly holding known voxels.
  void noteLayers(unsigned kz0, unsigned kz1);

  const octomap::OcTree& tree_;
  const LayerCache* cache_;
  // Per band layer: false while no voxel of it can be known (nothing reached it since the last
  // rebuild). A 2D lidar fills one layer of the band; the others then cost no octree search.
  std::vector<bool> layer_may_be_known_;
  SliceOptions options_;
  double resolution_;
  std::uint16_t band_lo_, band_hi_;
  std::uint16_t origin_key_x_ = 0, origin_key_y_ = 0;
  int width_ = 0, height_ = 0;
  // The band layers that may hold known voxels, each with its cached layer or null (the tree
  // then holds it): found once per batch of columns, so that a column's read skips the others.
  struct BandLayer {
    unsigned kz;
    const LayerCache::Layer* cached;
  };
  std::vector<BandLayer> band_layers_;
  std::vector<std::uint32_t> columns_;  // updateColumns' scratch: the columns to recompute
  std::vector<std::pair<std::uint32_t, int>> columns_moved_;  // shiftColumns' scratch: the shifts that change
  std::vector<std::int8_t> data_;
  std::uint64_t geometry_ = 0;
  std::unordered_map<std::uint32_t, int> shift_;  // the shifted columns
  std::array<std::uint32_t, 255> shift_counts_{};  // shift_'s columns per shift (clamped to a signed byte) + 127
  int shift_min_ = 0, shift_max_ = 0;              // bounds of their shifts (and 0)
  // shift_ over the grid's cells (as data_), for a lookup per changed voxel; empty while no
  // column is shifted. Shifts beyond a signed byte are clamped (6 m at 0.05 m).
  std::vector<std::int8_t> shift_grid_;
  void fillShiftGrid();
};

}  // namespace octo_slice_mapper
