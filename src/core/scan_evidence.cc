#include "octo_slice_mapper/internal/scan_evidence.h"

#include <algorithm>
#include <cstdlib>
#include <new>

#include <sys/mman.h>

#include "octo_slice_mapper/internal/octree_batch_update.h"

namespace octo_slice_mapper {

namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;

// Zero-filled words, mapped lazily by the system. The window is asked for transparent huge pages:
// walks touch it all over, so with 4 KiB pages they miss the TLB at most steps, and each page
// first read and then written faults twice (the zero page, then its own), with a TLB shootdown to
// the other pipeline worker. Where the system gives no huge pages, plain pages work the same.
std::uint32_t* mapWindow(std::size_t bytes) {
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) throw std::bad_alloc();
#ifdef MADV_HUGEPAGE
  madvise(p, bytes, MADV_HUGEPAGE);
#endif
  return static_cast<std::uint32_t*>(p);
}

std::size_t windowBytes(std::size_t cells) {
  return (cells * sizeof(std::uint32_t) + kHugePage - 1) / kHugePage * kHugePage;
}

}  // namespace

ScanEvidence::~ScanEvidence() {
  if (cells_) munmap(cells_, windowBytes(capacity_));
}

std::size_t ScanEvidence::memoryBytes() const {
  return (cells_ ? windowBytes(capacity_) : 0) + touched_capacity_ * sizeof(std::uint32_t) +
         block_masks_.capacity() * sizeof(std::uint64_t) + block_listed_.capacity() +
         blocks_in_order_.capacity() * sizeof(std::uint64_t);
}

namespace {
unsigned bitsFor(std::size_t n) {  // the smallest b with 2^b >= n
  unsigned b = 0;
  while ((std::size_t{1} << b) < n) ++b;
  return b;
}
}  // namespace

bool ScanEvidence::begin(const KeyBox& box, std::size_t max_adds) {
  // A scan that was never drained (its caller threw) must not leave evidence for the next one.
  for (std::size_t i = 0; i < count_; ++i) cells_[touched_[i]] = 0;
  count_ = 0;
  if (box.empty()) return false;
  const unsigned bx = bitsFor(std::size_t(box.max[0] - box.min[0]) + 1),
                 by = bitsFor(std::size_t(box.max[1] - box.min[1]) + 1);
  const std::size_t nz = std::size_t(box.max[2] - box.min[2]) + 1;
  if (bx + by >= 32 || (nz << (bx + by)) > kMaxCells) return false;
  const std::size_t cells = nz << (bx + by);
  if (cells > capacity_) {
    // Zero-filled and lazily mapped by the system: a larger window costs only the (huge) pages used.
    if (cells_) munmap(cells_, windowBytes(capacity_));
    cells_ = nullptr;
    capacity_ = 0;
    cells_ = mapWindow(windowBytes(cells));
    capacity_ = cells;
  }
  if (max_adds > touched_capacity_) {
    touched_capacity_ = std::max(max_adds, 2 * touched_capacity_);
    touched_.reset(new std::uint32_t[touched_capacity_]);
  }
  shift_y_ = bx;
  shift_z_ = bx + by;
  mask_x_ = (1u << bx) - 1;
  mask_y_ = (1u << by) - 1;
  lo_ = box.min;
  nz_ = nz;
  offset_ = (std::uint64_t(box.min[2]) << shift_z_) + (std::uint64_t(box.min[1]) << shift_y_) + box.min[0];
  return true;
}

namespace {

// Within a block: x | y << 3 | z << 6 (each 0-7) -> its place in the tree order, and back.
struct BlockOrder {
  std::uint16_t place[512], voxel[512];
  BlockOrder() {
    for (unsigned v = 0; v < 512; ++v) {
      const unsigned p = static_cast<unsigned>(treeOrder(octomap::OcTreeKey(v & 7, (v >> 3) & 7, v >> 6)));
      place[v] = static_cast<std::uint16_t>(p);
      voxel[p] = static_cast<std::uint16_t>(v);
    }
  }
};
const BlockOrder kBlockOrder;

}  // namespace

void ScanEvidence::orderInTree() {
  if (count_ == 0) return;
  // A key's tree order is its block's (the key >> 3, interleaved) followed by its low bits'.
  // The members in locals: the byte and word stores below could alias them, and were reloaded.
  const unsigned lx = lo_[0], ly = lo_[1], lz = lo_[2], shift_y = shift_y_, shift_z = shift_z_;
  const std::uint32_t mask_x = mask_x_, mask_y = mask_y_;
  const unsigned bx0 = lx >> 3, by0 = ly >> 3, bz0 = lz >> 3;
  const std::size_t nbx = ((lx + mask_x) >> 3) - bx0 + 1, nby = ((ly + mask_y) >> 3) - by0 + 1,
                    nbz = ((lz + nz_ - 1) >> 3) - bz0 + 1, layer = nbx * nby;
  if (block_listed_.size() < layer * nbz) {  // zero-filled; every use leaves them zero again
    block_masks_.resize(8 * layer * nbz);
    block_listed_.resize(layer * nbz);
  }
  std::uint64_t* const masks = block_masks_.data();
  std::uint8_t* const listed = block_listed_.data();
  std::uint32_t* const touched = touched_.get();
  blocks_in_order_.clear();
  for (std::size_t i = 0, n = count_; i < n; ++i) {
    const std::uint32_t index = touched[i];
    const unsigned x = (index & mask_x) + lx, y = ((index >> shift_y) & mask_y) + ly, z = (index >> shift_z) + lz;
    const std::size_t block = ((z >> 3) - bz0) * layer + ((y >> 3) - by0) * nbx + ((x >> 3) - bx0);
    if (!listed[block]) {
      listed[block] = 1;
      // Its tree order above the block's number: one sort of plain integers.
      const std::uint64_t order = treeOrder(octomap::OcTreeKey(x >> 3, y >> 3, z >> 3));
      blocks_in_order_.push_back(order << 24 | block);
    }
    const unsigned place = kBlockOrder.place[(x & 7) | (y & 7) << 3 | (z & 7) << 6];
    masks[8 * block + (place >> 6)] |= std::uint64_t{1} << (place & 63);
  }
  std::sort(blocks_in_order_.begin(), blocks_in_order_.end());
  const std::uint64_t offset = offset_;
  std::size_t n = 0;
  for (const std::uint64_t entry : blocks_in_order_) {
    const std::size_t block = entry & 0xFFFFFF;
    const std::uint64_t x0 = (block % nbx + bx0) << 3, y0 = (block / nbx % nby + by0) << 3,
                        z0 = (block / layer + bz0) << 3;
    const std::uint64_t base = (z0 << shift_z) + (y0 << shift_y) + x0 - offset;  // indexOf(x0, y0, z0)
    std::uint64_t* const mask = masks + 8 * block;
    for (unsigned w = 0; w < 8; ++w) {
      for (std::uint64_t bits = mask[w]; bits != 0; bits &= bits - 1) {
        const unsigned v = kBlockOrder.voxel[64 * w + static_cast<unsigned>(__builtin_ctzll(bits))];
        touched[n++] = static_cast<std::uint32_t>(base + (std::uint64_t(v >> 6) << shift_z) +
                                                  (std::uint64_t((v >> 3) & 7) << shift_y) + (v & 7));
      }
      mask[w] = 0;
    }
    listed[block] = 0;
  }
  count_ = n;  // each voxel once (a sum listed again after coming back to zero, too)
}

}  // namespace octo_slice_mapper
