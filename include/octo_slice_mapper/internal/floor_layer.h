// The floor under the map: per cell of the octree's x-y grid, the height of the floor the depth
// frames found there (a 2.5D layer), so that heights above the floor mean the same on a robot
// whose odom z = 0 is the floor, on a hand-held camera whose frame has the floor 1.5 m down, on a
// ramp and under a world turned by a degree or two.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
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
  // between two frames); a lower one always is (what was known may have been a table). Neither
  // this nor max_step below holds against a surface the frame's own returns climb to from the
  // floor known without a step (a ramp up to a platform: each cell's lowest return within half a
  // max_step of its neighbour's).
  double max_rise = 0.08;
  // Where the floor under the sensor was seen (not only followed from a plane), a level surface
  // more than this above it is a step's top, not the floor: a robot's low camera at a step sees
  // nothing else. Mapper sets it to cloud_mark_min_z: a surface that would mark is no floor.
  double max_step = 0.05;
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

// A cell's key coordinate (OctoMap's, for a tree of depth 16) along one axis, -1 outside, given
// 1 / resolution: rounded as OctoMap's coordToKey rounds (floor(c * (1 / resolution))), so that
// a floor cell is its octree column's; and the coordinate of a key's cell centre.
inline int floorKeyScaled(double coordinate, double inverse_resolution) {
  const double k = std::floor(coordinate * inverse_resolution) + 32768.0;
  return k < 0.0 ? -1 : k > 65535.0 ? -1 : static_cast<int>(k);
}
inline int floorKeyOf(double coordinate, double resolution) { return floorKeyScaled(coordinate, 1.0 / resolution); }
inline double floorCentreOf(int key, double resolution) { return (key - 32768 + 0.5) * resolution; }

// The floor one frame is measured against: the layer as it stood FloorLayer::kLag frames
// before it, and the frame's own plane.
class FloorView {
 public:
  static constexpr int kTileBits = 5;  // 32 x 32 cells per tile
  static constexpr int kTileSize = 1 << kTileBits;
  struct Tile {
    float height[kTileSize * kTileSize];  // NaN: not known
    std::uint8_t weight[kTileSize * kTileSize];
    // The layer's versions (read and written under its lock only): how many frames are folded in
    // once this one holds (its fold's frame + 1; a restored tile: those before the restore), and
    // the one before it, for frames measured against an older layer.
    std::uint64_t since = 0;
    mutable std::shared_ptr<const Tile> before;
  };
  // Where the cell of keys (kx, ky) lies in its tile.
  static int indexInTile(int kx, int ky) { return (ky & (kTileSize - 1)) * kTileSize + (kx & (kTileSize - 1)); }

  // The fixed frame's z = 0 everywhere.
  FloorView() = default;
  // The floor under (x, y): the cell's where known, else the plane of this frame or the last one
  // found before it, else (no floor ever found) the fixed frame's z = 0.
  // (Inline: it is asked once per return.)
  double heightAt(double x, double y) const {
    if (tiles_.empty()) return planeHeightAt(x, y);
    return heightAtKeys(floorKeyScaled(x, inverse_resolution_), floorKeyScaled(y, inverse_resolution_), x, y);
  }
  // The same for a point (x, y) known to lie in the cell of keys (kx, ky) (-1: outside the keys).
  double heightAtKeys(int kx, int ky, double x, double y) const {
    const int tx = (kx >> kTileBits) - tx0_, ty = (ky >> kTileBits) - ty0_;
    if (kx >= 0 && ky >= 0 && tx >= 0 && ty >= 0 && tx < tiles_x_ && ty < tiles_y_) {
      if (const Tile* tile = tiles_[std::size_t(ty) * tiles_x_ + tx].get()) {
        const float h = tile->height[indexInTile(kx, ky)];
        if (!std::isnan(h)) return h;
      }
    }
    return planeHeightAt(x, y);
  }

 private:
  friend class FloorLayer;
  double planeHeightAt(double x, double y) const { return plane_ ? plane_->heightAt(x, y) : 0.0; }
  double inverse_resolution_ = 1.0;
  int tx0_ = 0, ty0_ = 0, tiles_x_ = 0, tiles_y_ = 0;
  std::vector<std::shared_ptr<const Tile>> tiles_;  // row-major over the rectangle; null: none known
  std::optional<BoundedPlane> plane_;
};

// Thread-safe. Frames are numbered in the order they go into the map (take()). Frame f is
// measured against the layer as it stood once frames 0 .. f - kLag were folded in, and is folded
// in itself once every frame before it was: frames prepared in parallel (CloudPipeline) neither
// wait for the frame just before them nor see it, and the layer and every view are the same
// whichever frame's preparation ran first.
class FloorLayer {
 public:
  // How many frames back a frame's view of the layer stands. A pipeline of up to kLag workers
  // never waits for the layer (when a worker takes frame f, frames up to f - workers are done);
  // with more, a frame waits at most for the one kLag before it. A longer lag measures frames
  // against an older floor (4 lowered a simulated loop's recall below 0.97).
  static constexpr std::uint64_t kLag = 2;

  FloorLayer(double resolution, const FloorOptions& options);

  // The next frame's number.
  std::uint64_t take();
  // Finds frame `frame`'s floor among `samples` (map frame; its end-voxel means), seeded by the
  // floor known kLag frames before, and returns the view of the layer within `reach` (m) of the
  // sensor that its returns are measured against; the floor is folded in in the frame's turn, in
  // the columns within `reach` only (returns beyond the sensor's range are cut).
  // `cells`, when given, holds each sample's cell, the octree column it lies in (its end voxel's):
  // key x | key y << 16, or 0xffffffff for none (which the map's far corner cell, keys 65535 and
  // 65535, is taken for). Otherwise each sample's cell is that of its x and y.
  // `ground`, when given, is a point on the floor the sensor's carrier stands on (a robot's
  // base_footprint, map frame): the frame's floor is then the plane through it (within max_step)
  // or none, and is trusted over the layer: neither a table nor a floor below an edge is taken for
  // it, and a step the carrier climbed is its floor.
  // Waits (only) until frame - kLag has been folded in. A frame already folded in (inserted
  // anew after a reset) is measured against the layer as it is now and not folded in again.
  FloorView observe(std::uint64_t frame, const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
                    double reach, const std::vector<std::uint32_t>* cells = nullptr,
                    const std::optional<Eigen::Vector3d>& ground = std::nullopt);
  // observe(take(), ...): one frame after another.
  FloorView observe(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples, double reach,
                    const std::optional<Eigen::Vector3d>& ground = std::nullopt) {
    return observe(take(), sensor, samples, reach, nullptr, ground);
  }
  // Frame `frame` is not observed (refused before its floor was asked for): its turn passes.
  // Nothing when it was observed. Every number taken must be observed or passed.
  void pass(std::uint64_t frame);

  // Floor levels (height / resolution, rounded: the voxel layer the floor is in) for the slice.
  // The level where no cell is known follows the floors found, by whole voxels and only when it
  // is two or more voxels off, so that noise does not move the slice's band back and forth; a
  // cell's level is the layer nearest its own floor (levelOf).
  struct LevelChanges {
    int fallback_level = 0;
    bool fallback_changed = false;
    // (key x | key y << 16, level) changed since the last call; kNoLevel: the cell is unknown again.
    std::vector<std::pair<std::uint32_t, int>> cells;
  };
  static constexpr int kNoLevel = -0x7fffffff;
  // The changes not taken yet that the folds of the first `folded` frames made (all: every fold
  // so far), in fold order, with the fallback's level as of the last of them. A map that inserts
  // frame f takes those of folds 0 .. f: the same whichever later frames a pipeline has already
  // folded in, so that the slice follows the floor at the same frames in every run.
  LevelChanges takeLevelChanges(std::optional<std::uint64_t> folded = std::nullopt);
  int fallbackLevel() const;
  // The floor's height where no cell is known: the last found under a sensor (0 before any).
  double fallbackHeight() const;

  FloorStatus status() const;
  double resolution() const;
  // Every known cell's key x, key y and height.
  void forEachCell(const std::function<void(std::uint16_t, std::uint16_t, float)>& fn) const;
  // Forgets everything (a map reset or load); a new resolution when the map's changes.
  void reset(double resolution);
  // After reset(): the floor a saved map was found with (its height map): each (key x | key y << 16)
  // cell's height, and the height where no cell is known (the level plane of the last floor
  // found). Every frame to come is measured against it, and its levels are the next
  // takeLevelChanges(). The cells count as seen once (a frame's measurement soon outweighs them).
  void restore(const std::vector<std::pair<std::uint32_t, float>>& cells, double fallback_height);
  void setOptions(const FloorOptions& options);

 private:
  using Tile = FloorView::Tile;
  // What a frame is measured against, besides the tiles: the layer's scalars after a fold.
  struct Known {
    std::optional<BoundedPlane> last_plane;
    bool fallback_found = false;
    double fallback_height = 0.0;
  };
  // A frame's floor, measured on its worker, folded in in its turn.
  struct Fold {
    bool observed = false;  // false: passed
    Eigen::Vector3d sensor = Eigen::Vector3d::Zero();
    std::optional<BoundedPlane> plane;  // none: no floor found in the frame
    bool grounded = false;              // the plane passes through the carrier's ground point
    // The frame shows a walkable surface (a ramp) from the floor known up to its plane: a plane
    // above the floor known under the sensor is the floor all the same (the table rule spares it).
    bool reached = false;
    std::vector<std::uint32_t> floor_cells, other_cells;  // (key x | key y << 16), each once
  };
  static std::uint32_t tileId(int tx, int ty) { return std::uint32_t(tx) | std::uint32_t(ty) << 16; }
  // The keys of cell i of tile `id`.
  static int keyXOf(std::uint32_t id, int i) { return int(id & 0xffff) << FloorView::kTileBits | (i & (FloorView::kTileSize - 1)); }
  static int keyYOf(std::uint32_t id, int i) { return int(id >> 16) << FloorView::kTileBits | (i >> FloorView::kTileBits); }
  // The plane's height at a cell's centre.
  double heightAtCell(const BoundedPlane& plane, int kx, int ky) const {
    return plane.heightAt(floorCentreOf(kx, resolution_), floorCentreOf(ky, resolution_));
  }
  // Tile `id` as it stood once `folded` frames were folded in (null: none yet).
  const Tile* tileAsOf(std::uint32_t id, std::uint64_t folded) const;
  std::shared_ptr<const Tile> sharedTileAsOf(std::uint32_t id, std::uint64_t folded) const;
  Tile& writableTile(int tx, int ty);
  // The tile a fold wrote or looked at last: a frame's cells come in runs within a tile.
  struct LastTile {
    std::uint32_t id = 0xffffffff;
    Tile* tile = nullptr;    // null: none yet
    bool writable = false;   // the fold's own version (writableTile)
  };
  // The plane's floor measured in the cell (`seen`), or the plane extrapolated to a cell that
  // has none.
  void setCell(int kx, int ky, const BoundedPlane& plane, bool seen, LastTile* last);
  // The highest a level plane may stand at (x, y) and be the floor, once `folded` frames were
  // folded in: the cell's floor (`otherwise` where none is known) and max_rise above it, or
  // max_step where the cell's floor was seen.
  double highestFloorAt(double x, double y, std::uint64_t folded, double otherwise, const FloorOptions& options) const;
  // A cell's floor once a frame measured `measured` there: the running mean of the frames'
  // measurements, or the new one where none was seen (only extrapolated: weight 0) or it is
  // another surface (farther than the seed window).
  static bool replaces(float before, std::uint8_t weight, double measured, const FloorOptions& options) {
    return std::isnan(before) || weight == 0 || std::abs(measured - before) > options.fit.seed_window;
  }
  static double measuredMean(float before, std::uint8_t weight, double measured, const FloorOptions& options) {
    return replaces(before, weight, measured, options) ? measured : (before * weight + measured) / (weight + 1);
  }
  // The table rule: whether a frame's plane, seen from `sensor`, stands higher over the floor
  // known (`known`, the layer once `folded` frames were folded in) than a floor may (highestFloorAt).
  // Never for a plane through the carrier's ground point (`grounded`), nor for one the frame's
  // returns climb to from the floor known (`reached`, Fold::reached).
  bool aboveKnownFloor(const BoundedPlane& plane, bool grounded, bool reached, const Eigen::Vector3d& sensor,
                       const Known& known, std::uint64_t folded, const FloorOptions& options) const;
  // Whether it lies well below the floor known (farther than the seed window): what was taken for
  // the floor was a table, and the cells known are not this floor. Never for a grounded plane: the
  // known floor is then another level.
  static bool belowKnownFloor(const BoundedPlane& plane, bool grounded, const Eigen::Vector3d& sensor,
                              const Known& known, const FloorOptions& options);
  // A frame's floor measured against `known`: whether it is the floor, and the cells within
  // `reach` of the sensor (every cell for a reach of 0 or less) it speaks for.
  Fold measure(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
               const std::vector<std::uint32_t>* cells, const Known& known, const FloorOptions& options,
               double inverse_resolution, double reach, const std::optional<Eigen::Vector3d>& ground) const;
  // Folds in the frames whose turn it is (under the lock).
  void foldReady();
  void fold(const Fold& frame);
  // A cell's voxel layer: the one nearest its floor, so that the cell's band starts at most half
  // a voxel off the floor it is measured from. With more slack towards the fallback's layer, a
  // low step where the floor lies between two layers falls below its column's band (an 8 cm
  // step in a world turned 1 degree, at 0.05 m). A level floor's noise stays within one layer
  // unless the floor lies near a layer boundary; its columns are then shifted, which costs reads
  // (a shifted column is read voxel by voxel), not correctness.
  int levelOf(double height) const { return static_cast<int>(std::lround(height / resolution_)); }
  // Every known cell's level, as changes (a restore, whose cells no fold set).
  void relevel();

  mutable std::mutex mutex_;
  std::condition_variable folded_more_;
  double resolution_, inverse_resolution_;
  FloorOptions options_;
  std::unordered_map<std::uint32_t, std::shared_ptr<Tile>> tiles_;  // the newest versions
  std::optional<BoundedPlane> last_plane_;
  bool fallback_found_ = false;
  double fallback_height_ = 0.0;
  int fallback_level_ = 0;
  LevelChanges pending_;  // the fold in progress' (or a reset's, a restore's)
  // Changes not taken yet, by the number of frames folded in once they were made.
  std::map<std::uint64_t, LevelChanges> due_;
  int taken_level_ = 0;  // the fallback's level as of the changes last taken
  void makeDue();        // pending_ due now (at folded_)
  FloorStatus status_;
  std::uint64_t taken_ = 0;   // frame numbers given
  std::uint64_t folded_ = 0;  // frames folded in: 0 .. folded_ - 1
  std::uint64_t reset_at_ = 0;  // folded_ at the last reset
  std::map<std::uint64_t, Fold> waiting_;   // measured, their turn not yet come
  std::map<std::uint64_t, Known> known_;    // after `key` frames folded in, for the frames still to measure
};

}  // namespace octo_slice_mapper
