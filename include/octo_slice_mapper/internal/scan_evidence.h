// One scan's evidence per voxel, combined as the beams produce it: every voxel gets at most one
// update per scan, the sum of its beams' evidence or (octomap_server's rule) the strongest
// occupied evidence, else the strongest free one (see EvidenceCombining).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <type_traits>
#include <vector>

#include "octo_slice_mapper/internal/key_box.h"

namespace octo_slice_mapper {

enum class EvidenceCombining : std::uint8_t {
  // The beams of a scan are independent measurements: a voxel's update is the sum of theirs (the
  // log-odds form of Bayes' rule), clamped like any update when applied.
  kSum,
  // The largest occupied evidence wins; without any, the strongest free evidence (octomap_server's
  // KeySets do the same with hit/miss): a return is never erased by a beam of the same scan.
  kOccupiedWins,
};

// A dense window over the scan's key box holds one word per voxel; between scans it is all zero
// (drain() clears what the scan wrote), so starting a scan costs nothing.
//
// kOccupiedWins is a single unsigned max over code(value): positive values get the top bit, so
// they rank above every negative one, and a float's bits order like its magnitude. code() is
// exact and invertible: the update drain() hands on is one of the values add() was given.
// kSum keeps the running sum's float bits in the word. A voxel is listed when its word is 0 before
// an add: one whose sum came back to exactly zero is listed again by its next add, and drain()
// hands on its final value at its first listing and skips the later ones (its word is 0 then).
// drain() hands on no zero update.
class ScanEvidence {
 public:
  using Index = std::uint32_t;
  // Windows above this many voxels (each side rounded up to a power of two) would cost more
  // memory than they save (80 m beams at 0.02 m): begin() refuses them and the caller combines
  // the scan another way.
  static constexpr std::size_t kMaxCells = std::size_t{1} << 24;

  explicit ScanEvidence(EvidenceCombining combining = EvidenceCombining::kSum) : combining_(combining) {}
  ~ScanEvidence();
  ScanEvidence(const ScanEvidence&) = delete;
  ScanEvidence& operator=(const ScanEvidence&) = delete;

  // Starts a scan whose voxels all lie in `box` and that adds at most `max_adds` pieces of
  // evidence; false (and nothing started) if the box is larger than kMaxCells.
  bool begin(const KeyBox& box, std::size_t max_adds);
  // fn(rule) with the window's combining rule as a compile-time constant
  // (std::integral_constant<EvidenceCombining, C>): callers that add per voxel decide the rule
  // once per scan, not per add (per voxel the check was a tenth of an add's instructions).
  template <typename Fn>
  void withCombining(Fn&& fn) const {
    if (combining_ == EvidenceCombining::kSum) {
      fn(std::integral_constant<EvidenceCombining, EvidenceCombining::kSum>{});
    } else {
      fn(std::integral_constant<EvidenceCombining, EvidenceCombining::kOccupiedWins>{});
    }
  }
  // Evidence `value` (not zero: the caller filters out "no evidence") for `key`, which must lie in
  // the box given to begin().
  void add(const octomap::OcTreeKey& key, float value) {
    withCombining([&](auto rule) { addAs<decltype(rule)::value>(key, value); });
  }
  // add() for a window that combines by C, at the key or at the voxel's index in the window.
  template <EvidenceCombining C>
  __attribute__((always_inline)) inline void addAs(const octomap::OcTreeKey& key, float value) {
    addAtAs<C>(indexOf(key), value);
  }
  template <EvidenceCombining C>
  __attribute__((always_inline)) inline void addAtAs(Index index, float value) {
    std::uint32_t& cell = cells_[index];
    const std::uint32_t old = cell;
    cell = combine(C, old, value);
    touched_[count_] = index;  // kept only if the voxel had no evidence (branch-free)
    count_ += old == 0;
  }
  // The voxel's word as combined so far (0: no evidence yet).
  std::uint32_t wordAt(Index index) const { return cells_[index]; }
  // The window's voxels as a walk's indices (voxel_traversal.h): a voxel's index, the key of an
  // index and what a step along each axis adds. Linear in the key: the box's corner is folded
  // into offset_; power-of-two strides: an index converts back to its key by shifts and masks.
  Index indexOf(const octomap::OcTreeKey& key) const {
    const std::uint64_t linear = (std::uint64_t(key[2]) << shift_z_) + (std::uint64_t(key[1]) << shift_y_) + key[0];
    return static_cast<Index>(linear - offset_);
  }
  octomap::OcTreeKey keyOf(Index index) const {
    return octomap::OcTreeKey((index & mask_x_) + lo_[0], ((index >> shift_y_) & mask_y_) + lo_[1],
                              (index >> shift_z_) + lo_[2]);
  }
  Index stride(int axis) const { return axis == 0 ? 1u : axis == 1 ? Index{1} << shift_y_ : Index{1} << shift_z_; }
  // Calls fn(key, update) once per voxel that received evidence since begin(), in the order they
  // first did, and leaves the window empty for the next scan.
  template <typename Fn>
  void drain(Fn&& fn) {
    withCombining([&](auto rule) { drainAs<decltype(rule)::value>(fn); });
  }
  // Makes the next drain() hand on the voxels in the octree's order (OctoMap's child indices from
  // the root down, as sortInTreeOrder sorts: what applying a batch wants) instead of the order in
  // which they first got evidence. A bucket sort: each voxel is marked in a 512-bit mask of its
  // 8 x 8 x 8 block (blocks aligned in key space, so the order within one is its low key bits
  // interleaved), the few blocks are sorted by their own tree order, and the masks read in it.
  void orderInTree();
  // Voxels listed since begin(): at least as many as drain() will hand on.
  std::size_t listed() const { return count_; }
  // The bytes mapped for the window (whole huge pages) and the rest it holds. The window's size
  // is virtual: of it, only pages scans reached are resident. With orderInTree's scratch (about
  // 3 % of the window's size, once used).
  std::size_t memoryBytes() const;

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
  // A voxel's word after evidence `value` joins `word` (0: none yet), and the update it stands for.
  static std::uint32_t combine(EvidenceCombining combining, std::uint32_t word, float value) {
    if (combining == EvidenceCombining::kOccupiedWins) {
      const std::uint32_t c = code(value);
      return c > word ? c : word;
    }
    float sum;
    std::memcpy(&sum, &word, sizeof sum);  // word 0 is +0.0f
    sum += value;
    std::uint32_t bits;
    std::memcpy(&bits, &sum, sizeof bits);
    return bits;
  }
  static float decode(EvidenceCombining combining, std::uint32_t word) {
    if (combining == EvidenceCombining::kOccupiedWins) return value(word);
    float sum;
    std::memcpy(&sum, &word, sizeof sum);
    return sum;
  }
  EvidenceCombining combining() const { return combining_; }
  // Between scans only (the window empty): scans and clouds combine differently.
  void setCombining(EvidenceCombining combining) { combining_ = combining; }

 private:
  template <EvidenceCombining C, typename Fn>
  __attribute__((always_inline)) inline void drainAs(Fn& fn) {
    for (std::size_t i = 0; i < count_; ++i) {
      const std::uint32_t index = touched_[i];
      const float v = decode(C, cells_[index]);
      if (v != 0.0f) fn(keyOf(index), v);
      cells_[index] = 0;
    }
    count_ = 0;
  }
  EvidenceCombining combining_;
  std::uint32_t* cells_ = nullptr;  // mapped anew (mapWindow): pages a scan never reaches are never made resident
  std::size_t capacity_ = 0;
  unsigned shift_y_ = 0, shift_z_ = 0;
  std::uint32_t mask_x_ = 0, mask_y_ = 0;
  std::size_t nz_ = 0;
  std::uint64_t offset_ = 0;
  octomap::OcTreeKey lo_;
  std::unique_ptr<std::uint32_t[]> touched_;  // indices; the first count_ are this scan's voxels
  std::size_t touched_capacity_ = 0, count_ = 0;
  // orderInTree's scratch: a block's mask (8 words, all zero between calls) and whether it is
  // listed, per block of the window; the listed blocks with their tree order.
  std::vector<std::uint64_t> block_masks_;
  std::vector<std::uint8_t> block_listed_;
  std::vector<std::uint64_t> blocks_in_order_;
};

}  // namespace octo_slice_mapper
