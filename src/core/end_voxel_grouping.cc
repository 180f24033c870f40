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

// The points of a piece of a frame summed per end voxel through a small direct-mapped table of
// the voxels met last. An organized frame's neighbouring pixels end in a few voxels, and depth
// noise makes them alternate between two: summing runs of equal voxels instead, the end of a run
// was a mispredicted branch at every second or third point (82 000 of a desk frame's half, most
// of its time). A voxel's sum leaves the table when another voxel takes its slot, and at the end;
// a voxel may leave it more than once (the merge joins them).
// A slot sums the points' offsets from `reference` and their count as four floats, one SSE
// addition a point (in doubles, three conversions, additions and stores a point took a tenth of
// the grouping's time more). The offsets are small (a camera's range), so a mean keeps about
// seven digits of its distance from the reference; a sum leaves the table in doubles, the
// reference added back. (Without SSE2 the same float arithmetic, lane by lane.)
class PieceSums {
 public:
  PieceSums(EndVoxels* out, const Eigen::Vector3f& reference) : out_(out), reference_(reference.cast<double>()) {
    for (Slot& slot : slots_) slot.key = kEmpty;
    for (int d = 0; d < 3; ++d) offset_[d] = reference[d];
    offset_[3] = 0.0f;
  }
  // Point p, whose three key coordinates are k[0..2]. `wide`: the four floats from p on may be
  // read (p is not the last point of its array).
  template <bool wide>
  __attribute__((always_inline)) void add(const Eigen::Vector3f& p, const std::int32_t* k) {
    if ((k[0] | k[1] | k[2]) < 0) {  // no key: an organized frame's NaN pixels, or beyond the octree
      if (!p.allFinite()) out_->non_finite[nonFiniteKind(p)]++;
      else out_->outside.push_back(p.cast<double>());
      return;
    }
    const std::uint64_t key = std::uint64_t(k[0]) | std::uint64_t(k[1]) << 16 | std::uint64_t(k[2]) << 32;
    Slot& slot = slots_[slotOf(key, kSlotBits)];
#if defined(__SSE2__)
    const __m128 xyz = wide ? _mm_loadu_ps(p.data()) : _mm_setr_ps(p.x(), p.y(), p.z(), 0.0f);
    // The offsets and a 1 to count (the fourth float read, the next point's x, is masked out).
    const __m128 v = _mm_or_ps(_mm_and_ps(_mm_sub_ps(xyz, _mm_load_ps(offset_)),
                                          _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0))),
                               _mm_setr_ps(0.0f, 0.0f, 0.0f, 1.0f));
    if (slot.key == key) {
      _mm_store_ps(slot.sum, _mm_add_ps(_mm_load_ps(slot.sum), v));
      return;
    }
    if (slot.key != kEmpty) leave(slot);
    slot.key = key;
    _mm_store_ps(slot.sum, v);
#else
    const float v[4] = {p.x() - offset_[0], p.y() - offset_[1], p.z() - offset_[2], 1.0f};
    if (slot.key == key) {
      for (int d = 0; d < 4; ++d) slot.sum[d] += v[d];
      return;
    }
    if (slot.key != kEmpty) leave(slot);
    slot.key = key;
    for (int d = 0; d < 4; ++d) slot.sum[d] = v[d];
#endif
  }
  // The sums still in the table, out.
  void finish() {
    for (const Slot& slot : slots_) {
      if (slot.key != kEmpty) leave(slot);
    }
  }

 private:
  static constexpr unsigned kSlotBits = 8;  // 256 slots, 8 KB: two tables in the first-level cache
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // no key is (keys have 48 bits)
  struct alignas(32) Slot {
    float sum[4];  // the x, y, z offsets and the count (exact: a piece has fewer than 2^24 points)
    std::uint64_t key;
  };
  void leave(const Slot& slot) {
    const auto n = static_cast<std::uint64_t>(slot.sum[3]);
    out_->voxels.push_back({slot.key, Eigen::Vector3d(slot.sum[0], slot.sum[1], slot.sum[2]) + double(n) * reference_, n});
  }
  Slot slots_[1u << kSlotBits];
  EndVoxels* out_;
  Eigen::Vector3d reference_;
  alignas(16) float offset_[4];
};

// Pieces a and b of `points` ([begin, end) each), summed into out_a and out_b exactly as one after
// the other, but a point of each in turn: most points add to the slot the point before them added
// to, so a piece's sums are one chain of dependent additions through memory (a store, its load, an
// add), and two pieces' chains keep more of the core busy than one. b may be empty.
// The keys of a block of points are worked out first, without branches (keyCoordinates), and
// summed after (worked out and summed point by point, the two loops' branches and latencies
// added up).
void sumPiecePair(const std::vector<Eigen::Vector3f>& points, std::size_t begin_a, std::size_t end_a,
                  std::size_t begin_b, std::size_t end_b, double inverse, double centre,
                  const Eigen::Vector3f& reference, EndVoxels* out_a, EndVoxels* out_b) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points are packed x, y, z");
  constexpr std::size_t kBlock = 512;
  PieceSums a(out_a, reference), b(out_b, reference);
  // A room frame's points leave a table about every 15th.
  out_a->voxels.reserve((end_a - begin_a) / 8);
  out_b->voxels.reserve((end_b - begin_b) / 8);
  // The array's last point is read as three floats, after the others of its piece (b, unless b
  // is empty).
  const bool last_in_b = end_b > begin_b && end_b == points.size();
  const bool last_in_a = !last_in_b && end_a > begin_a && end_a == points.size();
  end_a -= last_in_a;
  end_b -= last_in_b;
  std::int32_t keys_a[3 * kBlock], keys_b[3 * kBlock];
  while (begin_a < end_a || begin_b < end_b) {
    const std::size_t na = std::min(kBlock, end_a - begin_a), nb = std::min(kBlock, end_b - begin_b);
    const Eigen::Vector3f* pa = points.data() + begin_a;
    const Eigen::Vector3f* pb = points.data() + begin_b;
    keyCoordinates(pa->data(), 3 * na, inverse, centre, keys_a);
    keyCoordinates(pb->data(), 3 * nb, inverse, centre, keys_b);
    const std::size_t both = std::min(na, nb);
    for (std::size_t i = 0; i < both; ++i) {
      a.add<true>(pa[i], keys_a + 3 * i);
      b.add<true>(pb[i], keys_b + 3 * i);
    }
    for (std::size_t i = both; i < na; ++i) a.add<true>(pa[i], keys_a + 3 * i);
    for (std::size_t i = both; i < nb; ++i) b.add<true>(pb[i], keys_b + 3 * i);
    begin_a += na;
    begin_b += nb;
  }
  if (last_in_a || last_in_b) {
    std::int32_t k[3];
    keyCoordinates(points.back().data(), 3, inverse, centre, k);
    (last_in_a ? a : b).add<false>(points.back(), k);
  }
  a.finish();
  b.finish();
}

}  // namespace

// Summed per piece of a fixed size first (sumPiecePair, the pieces on every core, joined in
// order), then the pieces' sums through an open-addressing table, in the order they come.
EndVoxels groupByEndVoxel(const std::vector<Eigen::Vector3f>& points, double resolution, unsigned depth,
                          unsigned threads, const Eigen::Vector3f& reference) {
  const double inverse = 1.0 / resolution;
  const double centre = static_cast<double>(1 << (depth - 1));
  // Pieces, not one chunk per core: the cost of a point differs across a frame (with runs of
  // equal voxels a desk frame's second half took twice its first's time), and pieces are shared
  // out as cores come free.
  constexpr std::size_t kPiece = std::size_t(1) << 14;
  const std::size_t pieces = (points.size() + kPiece - 1) / kPiece;
  std::vector<EndVoxels> parts(std::max<std::size_t>(1, pieces));
  const auto bound = [&](std::size_t piece) { return partStart(points.size(), piece, parts.size()); };
  // Shared out by pairs (sumPiecePair); a piece's sums are the same whatever its partner.
  const std::size_t pairs = (parts.size() + 1) / 2;
  const unsigned workers = workersFor(threads, points.size(), 2 * kPiece);
  forEachPiece(pairs, pairs, workers, [&](std::size_t, std::size_t, std::size_t pair) {
    const std::size_t a = 2 * pair, b = a + 1;
    const bool has_b = b < parts.size();
    EndVoxels none;
    sumPiecePair(points, bound(a), bound(a + 1), bound(a + 1), has_b ? bound(b + 1) : bound(a + 1), inverse, centre,
                 reference, &parts[a], has_b ? &parts[b] : &none);
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
