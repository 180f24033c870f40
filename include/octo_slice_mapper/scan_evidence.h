// One scan's evidence per voxel, combined as the beams produce it: every voxel gets at most one
// update per scan (see ScanInserter for the rule).
#pragma once


#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>

#include "octo_slice_mapper/key_box.h"

namespace octo_slice_mapper {

// A dense window over the scan's key box holds one word per voxel; between scans it is all zero
// (drain() clears what the scan wrote), so starting a scan costs nothing.
//
// The combining rule (the largest occupied evidence wins; without any, the strongest free
// evidence) is a single unsigned max over code(value): positive values get the top bit, so they
// rank above every negative one, and a float's bits order like its magnitude. code() is exact and
// invertible: the update drain() hands on is one of the values add() was given.
class ScanEvidence {
 public:
  // Windows above this many voxels would cost more memory than they save (80 m beams at 0.02 m):
  // begin() refuses them and the caller combines the scan another way.
  static constexpr std::size_t kMaxCells = std::size_t{1} << 24;

  ScanEvidence() = default;
  ~ScanEvidence();
  ScanEvidence(const ScanEvidence&) = delete;
  ScanEvidence& operator=(const ScanEvidence&) = delete;

  // Starts a scan whose voxels all lie in `box`; false (and nothing started) if the box is larger
  // than kMaxCells.
  bool begin(const KeyBox& box);
  // Evidence `value` for `key` (zero is no evidence), which must lie in the box given to begin().
  __attribute__((always_inline)) inline void add(const octomap::OcTreeKey& key, float value) {
    std::uint32_t& cell = cells_[index(key)];
    const std::uint32_t old = cell, c = code(value);
    cell = c > old ? c : old;
    if (count_ == touched_capacity_) grow();
    touched_[count_] = key;  // kept only if this is the voxel's first evidence (branch-free)
    count_ += (old == 0) & (c != 0);
  }
  // Calls fn(key, update) once per voxel that received evidence since begin(), in the order they
  // first did, and leaves the window empty for the next scan.
  template <typename Fn>
  void drain(Fn&& fn) {
    for (std::size_t i = 0; i < count_; ++i) {
      std::uint32_t& cell = cells_[index(touched_[i])];
      fn(touched_[i], value(cell));
      cell = 0;
    }
    count_ = 0;
  }
  // The window's size is virtual: of it, only pages scans reached are resident.
  std::size_t memoryBytes() const { return capacity_ * sizeof(std::uint32_t) + touched_capacity_ * sizeof(octomap::OcTreeKey); }

  static std::uint32_t code(float value) {
    const float magnitude = std::fabs(value);  // also clears the sign of -0
    std::uint32_t bits;
    std::memcpy(&bits, &magnitude, sizeof bits);
    return value > 0.0f ? bits | 0x80000000u : bits;
  }
  static float value(std::uint32_t code) {
    const std::uint32_t bits = code & 0x7FFFFFFFu;
    float magnitude;
    std::memcpy(&magnitude, &bits, sizeof magnitude);
    return code & 0x80000000u ? magnitude : -magnitude;
  }

 private:
  // Linear in the key: the box's corner is folded into offset_.
  std::size_t index(const octomap::OcTreeKey& key) const {
    return std::size_t(key[0] + key[1] * stride_y_ + key[2] * stride_z_ - offset_);
  }
  void grow();

  std::uint32_t* cells_ = nullptr;  // calloc'ed: pages a scan never reaches are never made resident
  std::size_t capacity_ = 0;
  std::int64_t stride_y_ = 0, stride_z_ = 0, offset_ = 0;
  std::unique_ptr<octomap::OcTreeKey[]> touched_;  // the first count_ are this scan's voxels
  std::size_t touched_capacity_ = 0, count_ = 0;
};

}  // namespace octo_slice_mapper
