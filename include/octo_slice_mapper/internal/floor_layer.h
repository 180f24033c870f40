// The floor under the map: per cell of the octree's x-y grid, the height of the floor the depth
// frames found there (a 2.5D layer), so that heights above the floor mean the same on a robot
// whose odom z = 0 is the floor, on a hand-held camera whose frame has the floor 1.5 m down, on a
// ramp and under a world turned by a degree or two.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "octo_slice_mapper/internal/floor_plane.h"

namespace octo_slice_mapper {

struct FloorOptions {
  // false: the floor is the fixed frame's z = 0 everywhere (as for a robot whose odom frame is
  // on the floor), and no frame is searched for it.
  bool find = true;
  FloorFitOptions fit;
  // A cell's height is the running mean of what the last this-many frames measured there; a
  // measurement farther than fit.seed_window from it replaces it (another surface).
  int memory_frames = 10;
  // Once a floor is known, a level surface found more than this (m) above it is not the floor
  // (a box, a seat, a table: a robot's floor does not step up by more than a ramp climbs
  // between two frames); a lower one always is (what was known may have been a table).
  double max_rise = 0.08;
  // Where a frame saw no floor, its plane is followed this far (m) beyond the floor it saw
  // (BoundedPlane).
  double extrapolation = 0.5;
};

// Where the floor of the last frame came from (/diagnostics).
enum class FloorSource : std::uint8_t {
  kAssumed,  // no floor was ever found: the fixed frame's z = 0
  kFound,    // found in the frame itself
  kKept,     // the frame showed none: the last one found is kept
};
const char* floorSourceName(FloorSource source);

struct FloorStatus {
  FloorSource source = FloorSource::kAssumed;
  double height = 0.0;  // m, the floor under the last frame's sensor
  double tilt = 0.0;    // rad, of the last plane found
  std::uint64_t frames_found = 0, frames_without = 0;
  std::size_t cells = 0;  // cells whose floor is known
};

// A cell's key coordinate (OctoMap's, for a tree of depth 16) along one axis, -1 outside; and the
// coordinate of a key's cell centre.
inline int floorKeyOf(double coordinate, double resolution) {
  const double k = std::floor(coordinate / resolution) + 32768.0;
  return k < 0.0 ? -1 : k > 65535.0 ? -1 : static_cast<int>(k);
}
inline double floorCentreOf(int key, double resolution) { return (key - 32768 + 0.5) * resolution; }

// The floor one frame is measured against, taken when the frame's own floor was folded in:
// frames prepared in parallel each see the layer as of their own turn.
class FloorView {
 public:
  static constexpr int kTileBits = 5;  // 32 x 32 cells per tile
  static constexpr int kTileSize = 1 << kTileBits;
  struct Tile {
    float height[kTileSize * kTileSize];  // NaN: not known
    std::uint8_t weight[kTileSize * kTileSize];
  };
  // Where the cell of keys (kx, ky) lies in its tile.
  static int indexInTile(int kx, int ky) { return (ky & (kTileSize - 1)) * kTileSize + (kx & (kTileSize - 1)); }

  // The fixed frame's z = 0 everywhere.
  FloorView() = default;
  // The floor under (x, y): the cell's where known, else the plane of this frame or the last one
  // found before it, else (no floor ever found) the fixed frame's z = 0.
  double heightAt(double x, double y) const;

 private:
  friend class FloorLayer;
  double resolution_ = 1.0;
  int tx0_ = 0, ty0_ = 0, tiles_x_ = 0, tiles_y_ = 0;
  std::vector<std::shared_ptr<const Tile>> tiles_;  // row-major over the rectangle; null: none known
  std::optional<BoundedPlane> plane_;
};

// Thread-safe. observe() must be called in the order the frames go into the map (the cloud
// pipeline's turns): each frame's floor is sought near the last one found.
class FloorLayer {
 public:
  FloorLayer(double resolution, const FloorOptions& options);

  // Finds the frame's floor among `samples` (map frame; a frame's end-voxel means), folds it in,
  // and returns the view of the layer within `reach` (m) of the sensor that the frame's returns
  // are measured against.
  FloorView observe(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples, double reach);

  // Floor levels (height / resolution, rounded: the voxel layer the floor is in) for the slice.
  // The level where no cell is known follows the floors found, by whole voxels and only when it
  // is two or more voxels off, so that noise does not move the slice's band back and forth; a
  // cell's level is that level unless its floor is three quarters of a voxel or more off it.
  struct LevelChanges {
    int fallback_level = 0;
    bool fallback_changed = false;
    // (key x | key y << 16, level) changed since the last call; kNoLevel: the cell is unknown again.
    std::vector<std::pair<std::uint32_t, int>> cells;
  };
  static constexpr int kNoLevel = -0x7fffffff;
  LevelChanges takeLevelChanges();
  int fallbackLevel() const;
  // The floor's height where no cell is known: the last found under a sensor (0 before any).
  double fallbackHeight() const;

  FloorStatus status() const;
  double resolution() const;
  // Every known cell's key x, key y and height.
  void forEachCell(const std::function<void(std::uint16_t, std::uint16_t, float)>& fn) const;
  // Forgets everything (a map reset or load); a new resolution when the map's changes.
  void reset(double resolution);
  void setOptions(const FloorOptions& options);

 private:
  using Tile = FloorView::Tile;
  static std::uint32_t tileId(int tx, int ty) { return std::uint32_t(tx) | std::uint32_t(ty) << 16; }
  // The keys of cell i of tile `id`.
  static int keyXOf(std::uint32_t id, int i) { return int(id & 0xffff) << FloorView::kTileBits | (i & (FloorView::kTileSize - 1)); }
  static int keyYOf(std::uint32_t id, int i) { return int(id >> 16) << FloorView::kTileBits | (i >> FloorView::kTileBits); }
  // The plane's height at a cell's centre.
  double heightAtCell(const BoundedPlane& plane, int kx, int ky) const {
    return plane.heightAt(floorCentreOf(kx, resolution_), floorCentreOf(ky, resolution_));
  }
  Tile& writableTile(int tx, int ty);
  // A floor measured in the cell (`seen`), or the frame's plane extrapolated to a cell that has none.
  void setCell(int kx, int ky, double height, bool seen);
  // The cell's floor at (x, y), or `otherwise` where none is known.
  double knownHeightAt(double x, double y, double otherwise) const;
  // A cell's voxel layer; within three quarters of a layer of the fallback's, the fallback's: a
  // level floor's noise and a few millimetres of tilt must not split it into shifted columns (a
  // shifted column is read voxel by voxel).
  int levelOf(double height) const {
    const double x = height / resolution_;
    return std::abs(x - fallback_level_) < 0.75 ? fallback_level_ : static_cast<int>(std::lround(x));
  }
  // Every known cell's level again (the fallback's level changed).
  void relevel();

  mutable std::mutex mutex_;
  double resolution_;
  FloorOptions options_;
  std::unordered_map<std::uint32_t, std::shared_ptr<Tile>> tiles_;
  std::optional<BoundedPlane> last_plane_;
  bool fallback_found_ = false;
  double fallback_height_ = 0.0;
  int fallback_level_ = 0;
  LevelChanges pending_;
  FloorStatus status_;
};

}  // namespace octo_slice_mapper
