#include "octo_slice_mapper/internal/layer_cache.h"

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
// search per voxel it changed and per layer of every slice column it changed.
std::unique_ptr<LayerCache::Tile> LayerCache::newTile(std::uint16_t z, unsigned kx, unsigned ky) const {
  const unsigned x0 = kx & ~kTileMask, y0 = ky & ~kTileMask;
  auto tile = std::make_unique<Tile>(unknownValue(), z, static_cast<std::uint16_t>(x0), static_cast<std::uint16_t>(y0));
  const unsigned depth = tree_->getTreeDepth();
  if (!tree_->search(octomap::OcTreeKey(kx, ky, z), depth - kTileBits)) return tile;
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

float LayerCache::valueInTree(const octomap::OcTreeKey& key) const {
  const octomap::OcTreeNode* node = tree_->search(key);
  return node ? node->getLogOdds() : unknownValue();
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

namespace {

// The positions p of a 64-bit mask whose bit b is set and bit a (a > b) clear: swapping bits a
// and b of every position moves these up by 2^a - 2^b.
constexpr std::uint64_t positionsToSwap(int a, int b) {
  std::uint64_t mask = 0;
  for (int p = 0; p < 64; ++p) {
    if (((p >> b) & 1) && !((p >> a) & 1)) mask |= std::uint64_t{1} << p;
  }
  return mask;
}

template <int a, int b>
std::uint64_t swapPositionBits(std::uint64_t m) {
  constexpr int d = (1 << a) - (1 << b);
  const std::uint64_t t = (m ^ (m >> d)) & positionsToSwap(a, b);
  return m ^ t ^ (t << d);
}

// An 8 x 8 mask with bit 8 y + x for cell (x, y) (bits y2 y1 y0 x2 x1 x0 of its position) turned
// into one with the bit at the cell's Morton position (y2 x2 y1 x1 y0 x0), OctoMap's order of
// the cells of one layer: three swaps of position bits.
std::uint64_t rowMajorToMorton(std::uint64_t m) {
  return swapPositionBits<2, 1>(swapPositionBits<4, 3>(swapPositionBits<3, 2>(m)));
}

// The x (even bits) and y (odd bits) of a 6-bit Morton position.
constexpr unsigned mortonX(unsigned k) { return (k & 1) | ((k >> 1) & 2) | ((k >> 2) & 4); }
constexpr unsigned mortonY(unsigned k) { return mortonX(k >> 1); }

// Bit i of the result set where byte i of v is not zero.
std::uint64_t nonZeroBytes(std::uint64_t v) {
  v |= v >> 4;
  v |= v >> 2;
  v |= v >> 1;
  return ((v & 0x0101010101010101ULL) * 0x0102040810204080ULL) >> 56;
}

}  // namespace

// Within a tile (fixed z, the same high bits of x and y) the octree's order is the Morton order
// of (x, y): 8 x 8 blocks in Morton order, the voxels of a block in Morton order.
void LayerCache::appendDirtyInTreeOrder(const Tile& tile, std::vector<KeyUpdate>* out) {
  static_assert(kTileSize == 64, "8 x 8 blocks of 8 x 8 voxels");
  std::uint64_t blocks = 0;  // bit 8 by + bx: block (bx, by) has a dirty voxel
  for (unsigned by = 0; by < 8; ++by) {
    std::uint64_t rows = 0;
    for (unsigned r = 0; r < 8; ++r) rows |= tile.dirty[8 * by + r];
    blocks |= nonZeroBytes(rows) << (8 * by);
  }
  for (std::uint64_t order = rowMajorToMorton(blocks); order != 0; order &= order - 1) {
    const unsigned block = unsigned(__builtin_ctzll(order));
    const unsigned bx = mortonX(block), by = mortonY(block);
    std::uint64_t cells = 0;  // bit 8 y + x: voxel (8 bx + x, 8 by + y) is dirty
    for (unsigned y = 0; y < 8; ++y) cells |= ((tile.dirty[8 * by + y] >> (8 * bx)) & 0xFF) << (8 * y);
    for (std::uint64_t in_block = rowMajorToMorton(cells); in_block != 0; in_block &= in_block - 1) {
      const unsigned k = unsigned(__builtin_ctzll(in_block));
      const unsigned x = 8 * bx + mortonX(k), y = 8 * by + mortonY(k);
      out->push_back({octomap::OcTreeKey(tile.x0 + x, tile.y0 + y, tile.z), tile.value[cellIndex(x, y)]});
    }
  }
}

std::size_t LayerCache::writeBack(Tile* tile) {
  flush_buffer_.clear();
  appendDirtyInTreeOrder(*tile, &flush_buffer_);
  std::fill(std::begin(tile->dirty), std::end(tile->dirty), 0);
  dirty_voxels_ -= tile->dirty_voxels;
  tile->dirty_voxels = 0;
  setSortedValues(tree_, flush_buffer_);
  return flush_buffer_.size();
}

void LayerCache::flush() { flushOldest(dirty_voxels_); }

void LayerCache::flushOldest(std::size_t count) {
  for (std::size_t written = 0; written < count && dirty_head_ < dirty_tiles_.size();) {
    written += writeBack(dirty_tiles_[dirty_head_++]);
  }
  if (dirty_head_ == dirty_tiles_.size()) {
    dirty_tiles_.clear();
    dirty_head_ = 0;
  } else if (dirty_head_ > dirty_tiles_.size() / 2) {  // the written part dropped now and then: O(1) per tile
    dirty_tiles_.erase(dirty_tiles_.begin(), dirty_tiles_.begin() + std::ptrdiff_t(dirty_head_));
    dirty_head_ = 0;
  }
}

void LayerCache::clear() {
  layers_.clear();
  dirty_tiles_.clear();
  dirty_head_ = 0;
  dirty_voxels_ = 0;
}

std::size_t LayerCache::memoryBytes() const {
  std::size_t bytes = sizeof(*this) + dirty_tiles_.capacity() * sizeof(Tile*) +
                      flush_buffer_.capacity() * sizeof(KeyUpdate);
  for (const auto& l : layers_) {
    bytes += sizeof(Layer) + l->tiles.capacity() * sizeof(std::unique_ptr<Tile>);
    for (const auto& t : l->tiles) bytes += t ? sizeof(Tile) : 0;
  }
  return bytes;
}

}  // namespace octo_slice_mapper
