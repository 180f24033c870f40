#include "octo_slice_mapper/scan_evidence.h"

#include <algorithm>
#include <cstdlib>
#include <new>

namespace octo_slice_mapper {

ScanEvidence::~ScanEvidence() { std::free(cells_); }

bool ScanEvidence::begin(const KeyBox& box) {
  count_ = 0;
  if (box.empty()) return false;
  const std::size_t nx = std::size_t(box.max[0] - box.min[0]) + 1, ny = std::size_t(box.max[1] - box.min[1]) + 1,
                    nz = std::size_t(box.max[2] - box.min[2]) + 1;
  const std::size_t cells = nx * ny * nz;
  if (cells > kMaxCells) return false;
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
  stride_y_ = std::int64_t(nx);
  stride_z_ = std::int64_t(nx * ny);
  offset_ = box.min[0] + box.min[1] * stride_y_ + box.min[2] * stride_z_;
  return true;
}

void ScanEvidence::grow() {
  const std::size_t capacity = 2 * touched_capacity_ + 4096;
  std::unique_ptr<octomap::OcTreeKey[]> grown(new octomap::OcTreeKey[capacity]);
  std::copy(touched_.get(), touched_.get() + count_, grown.get());
  touched_ = std::move(grown);
  touched_capacity_ = capacity;
}

}  // namespace octo_slice_mapper
