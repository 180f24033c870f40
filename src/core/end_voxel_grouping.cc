#include "core/internal/end_voxel_grouping.h"

#include <algorithm>
#include <cmath>

#include "core/internal/parallel_chunks.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace octo_slice_mapper {

// OctoMap's floor(c / resolution) + centre as floor(c * inverse + centre): in range the value is
// not negative, so the truncation is the floor, without a call to floor() per coordinate.
std::int32_t keyCoordinateOf(float coord, double inverse, double centre) {
  const double s = double(coord) * inverse + centre;
  return s >= 0.0 && s < 2.0 * centre ? static_cast<std::int32_t>(s) : kNoKeyCoordinate;  // NaN: none
}

void keyCoordinates(const float* coords, std::size_t count, double inverse, double centre, std::int32_t* keys) {
  std::size_t k = 0;
#if defined(__SSE2__)
  // Four floats per round, as two pairs of doubles: the same multiply, add, comparisons and
  // truncation as keyCoordinateOf (x86-64's baseline has no fused multiply-add that could round
  // one of them differently; a build with -mfma would be caught by end_voxel_grouping_test).
  const __m128d inv = _mm_set1_pd(inverse), cen = _mm_set1_pd(centre), limit = _mm_set1_pd(2.0 * centre);
  const __m128d zero = _mm_setzero_pd();
  const __m128i none = _mm_set1_epi32(kNoKeyCoordinate);
  for (; k + 4 <= count; k += 4) {
    const __m128 v = _mm_loadu_ps(coords + k);
    const __m128d lo = _mm_add_pd(_mm_mul_pd(_mm_cvtps_pd(v), inv), cen);
    const __m128d hi = _mm_add_pd(_mm_mul_pd(_mm_cvtps_pd(_mm_movehl_ps(v, v)), inv), cen);
    const __m128d inside_lo = _mm_and_pd(_mm_cmpge_pd(lo, zero), _mm_cmplt_pd(lo, limit));
    const __m128d inside_hi = _mm_and_pd(_mm_cmpge_pd(hi, zero), _mm_cmplt_pd(hi, limit));
    // The four 64-bit masks as 32-bit lanes, beside the four truncated keys.
    const __m128i inside =
        _mm_castps_si128(_mm_shuffle_ps(_mm_castpd_ps(inside_lo), _mm_castpd_ps(inside_hi), _MM_SHUFFLE(2, 0, 2, 0)));
    const __m128i truncated = _mm_unpacklo_epi64(_mm_cvttpd_epi32(lo), _mm_cvttpd_epi32(hi));
    const __m128i key = _mm_or_si128(_mm_and_si128(inside, truncated), _mm_andnot_si128(inside, none));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(keys + k), key);
  }
#endif
  for (; k < count; ++k) keys[k] = keyCoordinateOf(coords[k], inverse, centre);
}

namespace {

// A voxel key's slot in a table of 2^bits slots (Fibonacci hashing: the key's bits spread evenly).
std::size_t slotOf(std::uint64_t key, unsigned bits) {
  return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bits));
}

// The points of points[begin, end) summed per end voxel through a small direct-mapped table of
// the voxels met last. An organized frame's neighbouring pixels end in a few voxels, and depth
// noise makes them alternate between two: summing runs of equal voxels instead, the end of a run
// was a mispredicted branch at every second or third point (82 000 of a desk frame's half, most
// of its time). A voxel's sum leaves the table when another voxel takes its slot, and at the end;
// a voxel may leave it more than once (the merge joins them).
// The keys of a block of points are worked out first, without branches (keyCoordinates), and
// summed after (worked out and summed point by point, the two loops' branches and latencies
// added up).
void voxelSumsOf(const std::vector<Eigen::Vector3f>& points, std::size_t begin, std::size_t end, double inverse,
                 double centre, EndVoxels* out) {
  constexpr unsigned kSlotBits = 8;  // 256 slots, 10 KB: in the first-level cache
  struct Slot {
    std::uint64_t key;
    double x, y, z;  // not an Eigen vector: the compiler keeps the sums' arithmetic scalar and short
    std::uint64_t n;
  };
  Slot slots[1u << kSlotBits];
  for (Slot& slot : slots) slot.key = ~std::uint64_t{0}, slot.n = 0;
  constexpr std::size_t kBlock = 512;
  std::int32_t keys[3 * kBlock];
  out->voxels.reserve((end - begin) / 8);  // a room frame's points leave the table about every 15th
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points are packed x, y, z");
  for (std::size_t block = begin; block < end; block += kBlock) {
    const std::size_t n = std::min(kBlock, end - block);
    const Eigen::Vector3f* p = points.data() + block;
    keyCoordinates(p->data(), 3 * n, inverse, centre, keys);
    for (std::size_t i = 0; i < n; ++i) {
      const std::int32_t kx = keys[3 * i], ky = keys[3 * i + 1], kz = keys[3 * i + 2];
      if ((kx | ky | kz) < 0) {  // no key: an organized frame's NaN pixels, or beyond the octree
        if (!p[i].allFinite()) out->non_finite[nonFiniteKind(p[i])]++;
        else out->outside.push_back(p[i].cast<double>());
        continue;
      }
      const std::uint64_t key = std::uint64_t(kx) | std::uint64_t(ky) << 16 | std::uint64_t(kz) << 32;
      const double x = p[i].x(), y = p[i].y(), z = p[i].z();
      Slot& slot = slots[slotOf(key, kSlotBits)];
      if (slot.key == key) {
        slot.x += x, slot.y += y, slot.z += z;
        slot.n++;
        continue;
      }
      if (slot.n > 0) out->voxels.push_back({slot.key, Eigen::Vector3d(slot.x, slot.y, slot.z), slot.n});
      slot.key = key, slot.n = 1;
      slot.x = x, slot.y = y, slot.z = z;
    }
  }
  for (const Slot& slot : slots) {
    if (slot.n > 0) out->voxels.push_back({slot.key, Eigen::Vector3d(slot.x, slot.y, slot.z), slot.n});
  }
}

}  // namespace

// Summed per piece of a fixed size first (voxelSumsOf, the pieces on every core, joined in
// order), then the pieces' sums through an open-addressing table, in the order they come.
EndVoxels groupByEndVoxel(const std::vector<Eigen::Vector3f>& points, double resolution, unsigned depth,
                          unsigned threads) {
  const double inverse = 1.0 / resolution;
  const double centre = static_cast<double>(1 << (depth - 1));
  // Pieces, not one chunk per core: the cost of a point differs across a frame (with runs of
  // equal voxels a desk frame's second half took twice its first's time), and pieces are shared
  // out as cores come free.
  constexpr std::size_t kPiece = std::size_t(1) << 14;
  const std::size_t pieces = (points.size() + kPiece - 1) / kPiece;
  std::vector<EndVoxels> parts(std::max<std::size_t>(1, pieces));
  forEachPiece(points.size(), pieces, workersFor(threads, points.size(), kPiece),
               [&](std::size_t begin, std::size_t end, std::size_t piece) {
                 voxelSumsOf(points, begin, end, inverse, centre, &parts[piece]);
               });
  EndVoxels grouped;
  std::size_t sums = 0;
  for (const EndVoxels& part : parts) {
    grouped.non_finite += part.non_finite;
    grouped.outside.insert(grouped.outside.end(), part.outside.begin(), part.outside.end());
    sums += part.voxels.size();
  }
  unsigned bits = 4;
  while ((std::size_t(1) << bits) < 2 * sums) ++bits;
  std::vector<std::int32_t> table(std::size_t(1) << bits, -1);
  const std::size_t mask = table.size() - 1;
  std::vector<EndVoxel>& voxels = grouped.voxels;
  voxels.reserve(sums);
  for (const EndVoxels& part : parts) {
    for (const EndVoxel& sum : part.voxels) {
      std::size_t slot = slotOf(sum.key, bits);
      for (;; slot = (slot + 1) & mask) {
        if (table[slot] < 0) {
          table[slot] = static_cast<std::int32_t>(voxels.size());
          voxels.push_back(sum);
          break;
        }
        EndVoxel& g = voxels[static_cast<std::size_t>(table[slot])];
        if (g.key == sum.key) {
          g.sum += sum.sum;
          g.n += sum.n;
          break;
        }
      }
    }
  }
  return grouped;
}

}  // namespace octo_slice_mapper
