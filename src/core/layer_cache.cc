#include "octo_slice_mapper/layer_cache.h"

#include <algorithm>

namespace octo_slice_mapper {

LayerCache::LayerCache(octomap::OcTree* tree) : tree_(tree) {}

LayerCache::Layer& LayerCache::layer(std::uint16_t z) {
  if (const Layer* found = findLayer(z)) return *const_cast<Layer*>(found);  // ours: layers_ owns it
  layers_.push_back(std::make_unique<Layer>());
  layers_.back()->z = z;
  return *layers_.back();
}

const LayerCache::Layer* LayerCache::findLayer(std::uint16_t z) const {
  for (const auto& l : layers_) {
    if (l->z == z) return l.get();
  }
  return nullptr;
}

// Grows by at least half the current size per side, so a map growing at its edge re-allocates
// the directory O(log n) times. Tiles themselves never move (Refs point into them).
void LayerCache::cover(Layer* l, unsigned kx0, unsigned ky0, unsigned kx1, unsigned ky1) {
  const int tx0 = int(kx0 >> kTileBits), ty0 = int(ky0 >> kTileBits);
  const int tx1 = int(kx1 >> kTileBits), ty1 = int(ky1 >> kTileBits);
  if (l->ntx > 0 && tx0 >= l->tx0 && ty0 >= l->ty0 && tx1 < l->tx0 + l->ntx && ty1 < l->ty0 + l->nty) return;
  int nx0 = tx0, ny0 = ty0, nx1 = tx1, ny1 = ty1;
  if (l->ntx > 0) {
    const int mx = std::max(1, l->ntx / 2), my = std::max(1, l->nty / 2);
    nx0 = std::min(nx0 < l->tx0 ? nx0 - mx : l->tx0, nx0);
    ny0 = std::min(ny0 < l->ty0 ? ny0 - my : l->ty0, ny0);
    const int ox1 = l->tx0 + l->ntx - 1, oy1 = l->ty0 + l->nty - 1;
    nx1 = std::max(nx1 > ox1 ? nx1 + mx : ox1, nx1);
    ny1 = std::max(ny1 > oy1 ? ny1 + my : oy1, ny1);
  }
  constexpr int kMaxTile = (0xFFFF >> kTileBits);
  nx0 = std::max(nx0, 0), ny0 = std::max(ny0, 0);
  nx1 = std::min(nx1, kMaxTile), ny1 = std::min(ny1, kMaxTile);
  const int w = nx1 - nx0 + 1, h = ny1 - ny0 + 1;
  std::vector<std::unique_ptr<Tile>> grown(std::size_t(w) * h);
  for (int j = 0; j < l->nty; ++j) {
    for (int i = 0; i < l->ntx; ++i) {
      grown[std::size_t(l->ty0 + j - ny0) * w + (l->tx0 + i - nx0)] = std::move(l->tiles[std::size_t(j) * l->ntx + i]);
    }
  }
  l->tiles.swap(grown);
  l->tx0 = nx0, l->ty0 = ny0, l->ntx = w, l->nty = h;
}

// A new tile starts with every voxel of its layer the octree holds loaded, the rest unknown.
// Where the octree holds none of the 64 x 64 voxels (no node at the depth that spans them;
// typical while mapping new ground) one search tells. Else one walk over the tile's part of the
// layer: loaded voxel by voxel on first use instead, a tilted scan's new layers cost a root-to-leaf
// search per voxel it changed and per layer of every slice column it changed (issue 21).
std::unique_ptr<LayerCache::Tile> LayerCache::newTile(std::uint16_t z, unsigned kx, unsigned ky) const {
  auto tile = std::make_unique<Tile>(unknownValue());
  const unsigned depth = tree_->getTreeDepth();
  if (!tree_->search(octomap::OcTreeKey(kx, ky, z), depth - kTileBits)) return tile;
  const unsigned x0 = kx & ~kTileMask, y0 = ky & ~kTileMask;
  const octomap::OcTreeKey lo(x0, y0, z), hi(x0 + kTileMask, y0 + kTileMask, z);
  for (auto it = tree_->begin_leafs_bbx(lo, hi), end = tree_->end_leafs_bbx(); it != end; ++it) {
    // A leaf above the bottom (pruned) covers `span` keys per axis from its lower corner.
    const unsigned span = 1u << (depth - it.getDepth());
    const octomap::OcTreeKey k = it.getKey();
    const unsigned lx = k[0] & ~(span - 1), ly = k[1] & ~(span - 1), lz = k[2] & ~(span - 1);
    // The iterator also hands on leaves just outside the box (its overlap test is one key wide).
    if (z < lz || z > lz + span - 1) continue;
    const unsigned ix0 = std::max(lx, x0), ix1 = std::min(lx + span - 1, x0 + kTileMask);
    const unsigned iy0 = std::max(ly, y0), iy1 = std::min(ly + span - 1, y0 + kTileMask);
    const float value = it->getLogOdds();
    for (unsigned y = iy0; y <= iy1; ++y) {
      for (unsigned x = ix0; x <= ix1; ++x) {
        tile->value[cellIndex(x, y)] = value;
      }
    }
  }
  return tile;
}

// The arithmetic of OccupancyOcTreeBase::updateNode on one voxel: a voxel the octree does not
// hold starts at 0; one already at the bound the update pushes towards is left alone; else the
// update is added in float and the sum clamped.
bool LayerCache::applyTo(const Ref& ref, float update, VoxelChange* change) {
  float old = *ref.value;
  if (isUnloaded(old)) {
    const octomap::OcTreeNode* node = tree_->search(ref.key);
    old = node ? node->getLogOdds() : unknownValue();
    *ref.value = old;
  }
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
  if (!(*ref.dirty_row & ref.dirtyBit())) {
    *ref.dirty_row |= ref.dirtyBit();
    dirty_.push_back(ref);
  }
  return true;
}

bool LayerCache::apply(const octomap::OcTreeKey& key, float update, VoxelChange* change) {
  Layer& l = layer(key[2]);
  cover(&l, key[0], key[1], key[0], key[1]);
  return apply(l, key[0], key[1], update, change);
}

LayerCache::Lookup LayerCache::lookup(unsigned kx, unsigned ky, unsigned kz, float* value) const {
  const Layer* l = findLayer(static_cast<std::uint16_t>(kz));
  const Tile* tile = l ? l->tile(kx, ky) : nullptr;
  if (!tile) return Lookup::kNotCached;
  const float cached = tile->value[cellIndex(kx, ky)];
  if (isKnown(cached)) {
    *value = cached;
    return Lookup::kKnown;
  }
  return isUnloaded(cached) ? Lookup::kNotCached : Lookup::kUnknown;
}

void LayerCache::forget(const octomap::OcTreeKey& key) {
  const Layer* l = findLayer(key[2]);
  Tile* tile = l ? l->tile(key[0], key[1]) : nullptr;
  if (!tile) return;
  tile->value[cellIndex(key[0], key[1])] = unloadedValue();
}

void LayerCache::writeBack(std::size_t begin, std::size_t end) {
  flush_buffer_.clear();
  flush_buffer_.reserve(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    const Ref& ref = dirty_[i];
    flush_buffer_.push_back({ref.key, *ref.value});
    *ref.dirty_row &= ~ref.dirtyBit();
  }
  setValuesInTreeOrder(tree_, &flush_buffer_);
}

void LayerCache::flush() {
  if (dirtyCount() == 0) return;
  writeBack(dirty_head_, dirty_.size());
  dirty_.clear();
  dirty_head_ = 0;
  // A large one-off flush (offline mapping flushes once, at the end) must not keep its buffers.
  constexpr std::size_t kKeepCapacity = std::size_t{1} << 17;
  if (flush_buffer_.capacity() > kKeepCapacity) {
    flush_buffer_ = {};
    dirty_ = {};
  }
}

void LayerCache::flushOldest(std::size_t count) {
  const std::size_t end = dirty_head_ + std::min(count, dirtyCount());
  if (end == dirty_head_) return;
  writeBack(dirty_head_, end);
  dirty_head_ = end;
  if (dirty_head_ == dirty_.size()) {
    dirty_.clear();
    dirty_head_ = 0;
  } else if (dirty_head_ > dirty_.size() / 2) {  // the written part dropped now and then: O(1) per entry
    dirty_.erase(dirty_.begin(), dirty_.begin() + std::ptrdiff_t(dirty_head_));
    dirty_head_ = 0;
  }
}

void LayerCache::clear() {
  layers_.clear();
  dirty_.clear();
  dirty_head_ = 0;
}

std::size_t LayerCache::memoryBytes() const {
  std::size_t bytes = sizeof(*this) + dirty_.capacity() * sizeof(Ref) +
                      flush_buffer_.capacity() * sizeof(KeyUpdate);
  for (const auto& l : layers_) {
    bytes += sizeof(Layer) + l->tiles.capacity() * sizeof(std::unique_ptr<Tile>);
    for (const auto& t : l->tiles) bytes += t ? sizeof(Tile) : 0;
  }
  return bytes;
}

}  // namespace octo_slice_mapper
