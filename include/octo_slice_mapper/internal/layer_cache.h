// A write-back cache of horizontal octree layers: planar scans update dense tiles of log-odds
// instead of walking the octree per voxel, and the octree is brought up to date only when
// someone reads it (flush()).
#pragma once

#include <octomap/OcTree.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <vector>

#include "octo_slice_mapper/internal/octree_batch_update.h"

namespace octo_slice_mapper {

// Holds, per cached z layer, each touched voxel's log-odds exactly as the octree would hold it
// after the same updates: the per-voxel arithmetic of OctoMap's updateNode (early out at a
// clamping bound, float add, clamp) is repeated on the cached value, so flushing the values
// gives the same octree as calling updateNode for every update.
class LayerCache {
 public:
  static constexpr unsigned kTileBits = 6;  // 64 x 64 voxels per tile
  static constexpr unsigned kTileSize = 1u << kTileBits;
  static constexpr unsigned kTileMask = kTileSize - 1;

  // A voxel's value is its log-odds, or one of two NaNs when it has none: kUnknownBits (the
  // octree holds no node for it) and kUnloadedBits (the octree is current for it: read it there).
  // One load per voxel then answers both "is it known?" and "is it at its bound?" (a NaN fails
  // every comparison), where a separate state array cost a second cache line per voxel: the
  // slice reads every band layer of a changed column, five for a tilted scan.
  static constexpr std::uint32_t kUnknownBits = 0x7FC00001u, kUnloadedBits = 0x7FC00002u;
  static float unknownValue() { return fromBits(kUnknownBits); }
  static float unloadedValue() { return fromBits(kUnloadedBits); }
  static bool isKnown(float value) { return value == value; }
  static bool isUnloaded(float value) { return bitsOf(value) == kUnloadedBits; }
  struct Tile {
    // Every voxel starts as `initial` (no default: zero would be a known log-odds). The tile
    // holds voxels (x0 .. x0 + 63, y0 .. y0 + 63) of layer z.
    Tile(float initial, std::uint16_t z, std::uint16_t x0, std::uint16_t y0) : z(z), x0(x0), y0(y0) {
      std::fill(std::begin(value), std::end(value), initial);
    }
    float value[kTileSize * kTileSize];
    // Bit (kx & kTileMask) of row (ky & kTileMask): the octree lags behind the cached value.
    std::uint64_t dirty[kTileSize] = {};
    std::uint16_t z, x0, y0;
    std::uint32_t dirty_voxels = 0;  // bits set in `dirty`
  };
  // Appends the tile's dirty voxels with their values to `out`, in the octree's order (as
  // sortInTreeOrder puts them), read from the dirty bits 8 x 8 voxels at a time.
  static void appendDirtyInTreeOrder(const Tile& tile, std::vector<KeyUpdate>* out);
  // A dense directory of tiles over a rectangle of tile coordinates that grows as needed.
  struct Layer {
    std::uint16_t z = 0;
    int tx0 = 0, ty0 = 0, ntx = 0, nty = 0;
    std::vector<std::unique_ptr<Tile>> tiles;
    bool covers(unsigned kx, unsigned ky) const {
      const int tx = int(kx >> kTileBits) - tx0, ty = int(ky >> kTileBits) - ty0;
      return tx >= 0 && ty >= 0 && tx < ntx && ty < nty;
    }
    // The directory slot of the tile holding (kx, ky), which the layer must cover.
    std::size_t slotIndex(unsigned kx, unsigned ky) const {
      return std::size_t(int(ky >> kTileBits) - ty0) * ntx + (int(kx >> kTileBits) - tx0);
    }
    std::unique_ptr<Tile>& slot(unsigned kx, unsigned ky) { return tiles[slotIndex(kx, ky)]; }
    // The tile holding (kx, ky), or null when none was made there.
    Tile* tile(unsigned kx, unsigned ky) const { return covers(kx, ky) ? tiles[slotIndex(kx, ky)].get() : nullptr; }
  };
  // Where (kx, ky) lies inside its tile.
  static unsigned cellIndex(unsigned kx, unsigned ky) { return ((ky & kTileMask) << kTileBits) | (kx & kTileMask); }

  explicit LayerCache(octomap::OcTree* tree);

  // The cached layer at z (created empty on first use).
  Layer& layer(std::uint16_t z);
  const Layer* findLayer(std::uint16_t z) const;
  // Whether updates of layer z go into the cache (else straight into the octree): its cached
  // layers', and every layer's while holdEverything is on (the octree is lent to a reader and must
  // not change; its owner must not flush meanwhile).
  bool holds(std::uint16_t z) const { return hold_everything_ || findLayer(z); }
  void holdEverything(bool on) { hold_everything_ = on; }
  bool empty() const { return layers_.empty(); }
  // Grows `layer`'s directory to cover the key rectangle (call before apply() in it).
  void cover(Layer* layer, unsigned kx0, unsigned ky0, unsigned kx1, unsigned ky1);

  // One update of voxel (kx, ky) of `layer`, which must cover it; false if the value did not change,
  // else the change goes to `change` (when given).
  __attribute__((always_inline)) inline bool apply(Layer& layer, unsigned kx, unsigned ky, float update,
                                                   VoxelChange* change = nullptr) {
    std::unique_ptr<Tile>& slot = layer.slot(kx, ky);
    if (!slot) slot = newTile(layer.z, kx, ky);
    const unsigned index = cellIndex(kx, ky);
    // Most updates of a mapped area push a voxel already at its bound (free space seen again):
    // updateNode's early out, decided here without a call (false for a voxel without a value).
    const float old = slot->value[index];
    if (update >= 0.0f ? old >= tree_->getClampingThresMaxLog() : old <= tree_->getClampingThresMinLog()) return false;
    return applyTo({&slot->value[index], slot.get(), octomap::OcTreeKey(kx, ky, layer.z)}, update,
                   change);
  }
  // The same for a voxel of any layer (cached from now on).
  bool apply(const octomap::OcTreeKey& key, float update, VoxelChange* change = nullptr);

  // Log-odds of a voxel of a cached layer: kNotCached when its layer is not cached or the voxel
  // not loaded (then the octree is up to date for it), else kUnknown / kKnown with `value`.
  enum class Lookup { kNotCached, kUnknown, kKnown };
  Lookup lookup(unsigned kx, unsigned ky, unsigned kz, float* value) const;

  // After the octree's value of `key` was changed behind the cache's back (the cache must hold
  // nothing unflushed for it): the next use reads it from the octree again.
  void forget(const octomap::OcTreeKey& key);
  // Writes every value the octree lags behind into it. The cache stays valid.
  void flush();
  // Writes at least `count` values (all, if fewer wait), a whole tile at a time: the tiles whose
  // first waiting value has waited longest. A backlog is kept bounded a little at a time instead
  // of all at once.
  void flushOldest(std::size_t count);
  // Forgets everything (after the octree was changed behind the cache's back, e.g. replaced).
  void clear();
  std::size_t dirtyCount() const { return dirty_voxels_; }
  std::size_t memoryBytes() const;

 private:
  struct Ref {
    float* value = nullptr;
    Tile* tile = nullptr;  // the voxel's
    octomap::OcTreeKey key;
    std::uint64_t& dirtyRow() const { return tile->dirty[key[1] & kTileMask]; }
    std::uint64_t dirtyBit() const { return std::uint64_t{1} << (key[0] & kTileMask); }
  };
  static float fromBits(std::uint32_t bits) {
    float value;
    std::memcpy(&value, &bits, sizeof(value));
    return value;
  }
  static std::uint32_t bitsOf(float value) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, sizeof(bits));
    return bits;
  }
  std::unique_ptr<Tile> newTile(std::uint16_t z, unsigned kx, unsigned ky) const;
  // The octree's value of a voxel (unknownValue() when it holds none).
  float valueInTree(const octomap::OcTreeKey& key) const;
  // The arithmetic of OccupancyOcTreeBase::updateNode on one voxel: a voxel the octree does not
  // hold starts at 0; one already at the bound the update pushes towards is left alone; else the
  // update is added in float and the sum clamped. Inline: it runs once per changed voxel, and a
  // tilted scan changes more than twice as many voxels as a level one.
  __attribute__((always_inline)) inline bool applyTo(const Ref& ref, float update, VoxelChange* change = nullptr) {
    float old = *ref.value;
    if (__builtin_expect(isUnloaded(old), 0)) *ref.value = old = valueInTree(ref.key);
    const bool known = isKnown(old);
    const float lo = tree_->getClampingThresMinLog(), hi = tree_->getClampingThresMaxLog();
    float value = 0.0f;
    if (known) {
      if ((update >= 0.0f && old >= hi) || (update <= 0.0f && old <= lo)) return false;
      value = old;
    }
    value += update;
    if (value < lo) {
      value = lo;
    } else if (value > hi) {
      value = hi;
    }
    if (known && value == old) return false;
    *ref.value = value;
    if (change) *change = {old, value};
    std::uint64_t& row = ref.dirtyRow();
    if (!(row & ref.dirtyBit())) {
      row |= ref.dirtyBit();
      ++dirty_voxels_;
      if (ref.tile->dirty_voxels++ == 0) dirty_tiles_.push_back(ref.tile);
    }
    return true;
  }

  octomap::OcTree* tree_;
  bool hold_everything_ = false;
  std::vector<std::unique_ptr<Layer>> layers_;
  // Writes the tile's dirty voxels into the octree; how many.
  std::size_t writeBack(Tile* tile);

  // The tiles holding values the octree lags behind, from dirty_head_ on, in the order their first
  // such value came. A tile's voxels are written together, in tree order straight from its dirty
  // bits: a list of the voxels had to be sorted first, a third of a tilted session's writes into
  // the octree.
  std::vector<Tile*> dirty_tiles_;
  std::size_t dirty_head_ = 0;  // dirty_tiles_[0, dirty_head_) were written by flushOldest
  std::size_t dirty_voxels_ = 0;
  std::vector<KeyUpdate> flush_buffer_;
};

}  // namespace octo_slice_mapper
