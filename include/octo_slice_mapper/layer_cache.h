// A write-back cache of horizontal octree layers: planar scans update dense tiles of log-odds
// instead of walking the octree per voxel, and the octree is brought up to date only when
// someone reads it (flush()).
#pragma once

#include <octomap/OcTree.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "octo_slice_mapper/key_box.h"
#include "octo_slice_mapper/octree_batch_update.h"

namespace octo_slice_mapper {

// Holds, per cached z layer, each touched voxel's log-odds exactly as the octree would hold it
// after the same updates: the per-voxel arithmetic of OctoMap's updateNode (early out at a
// clamping bound, float add, clamp) is repeated on the cached value, so flushing the values
// gives the same octree as calling updateNode for every update.
//
// Use per scan: beginScan(), add() for every (voxel, evidence) the beams produce, then
// endScan(), which combines each voxel's evidence of the scan and applies it.
class LayerCache {
 public:
  static constexpr unsigned kTileBits = 6;  // 64 x 64 voxels per tile
  static constexpr unsigned kTileSize = 1u << kTileBits;
  static constexpr unsigned kTileMask = kTileSize - 1;

  struct Cell {
    float value = 0.0f;  // log-odds, valid once loaded
    float pos = 0.0f;    // this scan's strongest occupied evidence
    float neg = 0.0f;    // and strongest free evidence
    std::uint32_t stamp = 0;  // the scan pos / neg belong to
  };
  // Cell states; kDirty is or-ed in while the octree lags behind the cached value.
  enum : std::uint8_t { kUnloaded = 0, kUnknown = 1, kKnown = 2, kLoadMask = 3, kDirty = 4 };
  struct Tile {
    Cell cells[kTileSize * kTileSize];
    std::uint8_t state[kTileSize * kTileSize] = {};
  };
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
  bool empty() const { return layers_.empty(); }
  // Grows `layer`'s directory to cover the key rectangle (call before add() in it).
  void cover(Layer* layer, unsigned kx0, unsigned ky0, unsigned kx1, unsigned ky1);

  void beginScan();
  // Evidence `value` of the current scan for voxel (kx, ky) of `layer`, which must cover it.
  // Per voxel and scan the largest positive evidence wins, else the most negative one.
  __attribute__((always_inline)) inline void add(Layer& layer, unsigned kx, unsigned ky, float value) {
    std::unique_ptr<Tile>& slot = layer.slot(kx, ky);
    if (!slot) slot = std::make_unique<Tile>();
    const unsigned index = cellIndex(kx, ky);
    Cell& cell = slot->cells[index];
    // The evidence combined branch-free (whether it is the strongest so far is unpredictable);
    // only a voxel's first evidence of the scan records it (beams overlap near the sensor).
    const bool fresh = cell.stamp != stamp_;
    cell.stamp = stamp_;
    const float pos = fresh ? 0.0f : cell.pos, neg = fresh ? 0.0f : cell.neg;
    cell.pos = value > pos ? value : pos;
    cell.neg = value < neg ? value : neg;
    if (fresh) {
      if (touched_count_ == touched_.size()) touched_.resize(2 * touched_.size() + 1024);
      touched_[touched_count_++] = {&cell, &slot->state[index], octomap::OcTreeKey(kx, ky, layer.z)};
    }
  }
  // Applies the scan's combined evidence. Appends the keys whose log-odds changed to `changed`,
  // adds every voxel that received a non-zero update to `updated`, and returns how many did.
  std::size_t endScan(std::vector<octomap::OcTreeKey>* changed, KeyBox* updated);

  // One update of a voxel in a cached layer (for updates computed elsewhere); false if the
  // value did not change.
  bool apply(const octomap::OcTreeKey& key, float update);

  // Log-odds of a voxel of a cached layer: kNotCached when its layer is not cached or the voxel
  // not loaded (then the octree is up to date for it), else kUnknown / kKnown with `value`.
  enum class Lookup { kNotCached, kUnknown, kKnown };
  Lookup lookup(unsigned kx, unsigned ky, unsigned kz, float* value) const;

  // After the octree's value of `key` was changed behind the cache's back (the cache must hold
  // nothing unflushed for it): the next use reads it from the octree again.
  void forget(const octomap::OcTreeKey& key);
  // Writes every value the octree lags behind into it. The cache stays valid.
  void flush();
  // Forgets everything (after the octree was changed behind the cache's back, e.g. replaced).
  void clear();
  std::size_t dirtyCount() const { return dirty_.size(); }
  std::size_t memoryBytes() const;

 private:
  struct Ref {
    Cell* cell = nullptr;
    std::uint8_t* state = nullptr;
    octomap::OcTreeKey key;
  };
  Cell* cellFor(const octomap::OcTreeKey& key, std::uint8_t** state);
  bool applyTo(const Ref& ref, float update);

  octomap::OcTree* tree_;
  std::vector<std::unique_ptr<Layer>> layers_;
  std::uint32_t stamp_ = 0;
  std::vector<Ref> touched_;  // voxels with evidence in the current scan: the first touched_count_
  std::size_t touched_count_ = 0;
  std::vector<Ref> dirty_;    // voxels the octree lags behind
  std::vector<KeyUpdate> flush_buffer_;
};

}  // namespace octo_slice_mapper
