// Octree keys: a safe coordinate -> key conversion, and a bounding box of keys used to limit work
// to what a scan touched.
#pragma once

#include <octomap/OcTree.h>
#include <octomap/OcTreeKey.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace octo_slice_mapper {

// OctoMap's coordToKeyChecked casts the scaled coordinate to int before its range check, which is
// undefined behaviour for a coordinate that is not finite or far outside the tree (found by
// fuzzing: a finite pose of 1e308 m, or a 3e38 m reading under range_max = FLT_MAX). This checks
// the range in double first, then computes OctoMap's key, floor(coordinate / resolution) + the
// centre key, with OctoMap's own arithmetic (the factor 1 / resolution as OcTreeBaseImpl keeps
// it) but inline and with the floor taken from the truncation: through the tree it was an
// out-of-line call and a libm floor() per axis, for every ray end of every scan and frame.
inline bool coordToKeySafe(const octomap::OcTree& tree, double x, double y, double z, octomap::OcTreeKey* key) {
  const double resolution = tree.getResolution();
  const int centre = 1 << (tree.getTreeDepth() - 1);  // OctoMap's tree_max_val
  const double half_extent = resolution * centre;
  if (!(std::abs(x) < half_extent && std::abs(y) < half_extent && std::abs(z) < half_extent)) return false;
  const double factor = 1. / resolution;  // OcTreeBaseImpl's resolution_factor
  const auto keyOf = [&](double coordinate, octomap::key_type* k) {
    const double scaled = factor * coordinate;  // within (-centre, centre] after the check above
    int floored = static_cast<int>(scaled);      // truncation, then down for negative non-integers
    floored -= scaled < static_cast<double>(floored);
    const int v = floored + centre;
    if (v < 0 || v >= 2 * centre) return false;
    *k = static_cast<octomap::key_type>(v);
    return true;
  };
  octomap::OcTreeKey k;
  if (!keyOf(x, &k[0]) || !keyOf(y, &k[1]) || !keyOf(z, &k[2])) return false;
  *key = k;
  return true;
}

struct KeyBox {
  octomap::OcTreeKey min{0xFFFF, 0xFFFF, 0xFFFF};
  octomap::OcTreeKey max{0, 0, 0};

  bool empty() const { return min[0] > max[0]; }
  void add(const octomap::OcTreeKey& k) {
    for (int i = 0; i < 3; ++i) {
      min[i] = std::min(min[i], k[i]);
      max[i] = std::max(max[i], k[i]);
    }
  }
  void add(const KeyBox& other) {
    if (other.empty()) return;
    add(other.min);
    add(other.max);
  }
  // The box of `keys` (empty for none). A scan's changed keys (2 000 for a tilted one, tens of
  // thousands for a depth frame): key by key, the three minima and maxima cost about 40
  // instructions per key, so eight keys at a time (below).
  static KeyBox of(const std::vector<octomap::OcTreeKey>& keys) {
    KeyBox box;
    std::size_t i = 0;
#if defined(__SSE2__)
    static_assert(sizeof(octomap::OcTreeKey) == 6, "a key is three packed 16-bit words");
    const std::size_t n = keys.size();
    if (n >= 8) {
      // Eight keys are 24 words, three vectors; word w of them belongs to axis w % 3. SSE2 has
      // only signed 16-bit minima and maxima: the words are compared with their top bit flipped.
      const __m128i flip = _mm_set1_epi16(static_cast<short>(0x8000));
      __m128i lo[3], hi[3];
      for (int v = 0; v < 3; ++v) lo[v] = _mm_set1_epi16(0x7FFF), hi[v] = _mm_set1_epi16(static_cast<short>(0x8000));
      const unsigned char* words = reinterpret_cast<const unsigned char*>(keys.data());
      for (; i + 8 <= n; i += 8) {
        for (int v = 0; v < 3; ++v) {
          const __m128i x = _mm_xor_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(words + 6 * i + 16 * v)), flip);
          lo[v] = _mm_min_epi16(lo[v], x);
          hi[v] = _mm_max_epi16(hi[v], x);
        }
      }
      std::uint16_t low[24], high[24];
      for (int v = 0; v < 3; ++v) {
        _mm_storeu_si128(reinterpret_cast<__m128i*>(low + 8 * v), _mm_xor_si128(lo[v], flip));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(high + 8 * v), _mm_xor_si128(hi[v], flip));
      }
      for (int w = 0; w < 24; ++w) {
        box.min[w % 3] = std::min(box.min[w % 3], low[w]);
        box.max[w % 3] = std::max(box.max[w % 3], high[w]);
      }
    }
#endif
    for (; i < keys.size(); ++i) box.add(keys[i]);
    return box;
  }
};

}  // namespace octo_slice_mapper
