#include "octo_slice_mapper/scan_evidence.h"

#include <algorithm>
#include <cstdlib>
#include <new>

namespace octo_slice_mapper {

ScanEvidence::~ScanEvidence() { std::free(cells_); }

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
    // Zero-filled and lazily mapped by the system: a larger window costs only the pages used.
    std::free(cells_);
    cells_ = static_cast<std::uint32_t*>(std::calloc(cells, sizeof(std::uint32_t)));
    if (!cells_) {
      capacity_ = 0;
      throw std::bad_alloc();
    }
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
  offset_ = (std::uint64_t(box.min[2]) << shift_z_) + (std::uint64_t(box.min[1]) << shift_y_) + box.min[0];
  return true;
}

}  // namespace octo_slice_mapper
