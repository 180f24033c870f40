#include "octo_slice_mapper/internal/flying_pixels.h"

#include <algorithm>
#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace octo_slice_mapper {

std::size_t flagFlyingPixels(const std::vector<Eigen::Vector3f>& organized, int width, int height,
                             const FlyingPixelOptions& options, std::vector<std::uint8_t>* flags) {
  flags->clear();
  if (!options.enabled || width < 3 || height < 3 || organized.size() != std::size_t(width) * height) return 0;
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "three packed floats");
  std::vector<float> range(organized.size());
  const float* xyz = organized.data()->data();
  for (std::size_t i = 0; i < organized.size(); ++i) {
    const float x = xyz[3 * i], y = xyz[3 * i + 1], z = xyz[3 * i + 2];
    range[i] = std::sqrt(x * x + y * y + z * z);  // NaN stays NaN: it is close to nothing
  }
  flags->resize(range.size());
  std::size_t count = 0;
  for (int v = 0; v < height; ++v) {
    const float* row = &range[std::size_t(v) * width];
    count += flagFlyingRow(v > 0 ? row - width : nullptr, row, v + 1 < height ? row + width : nullptr, width, options,
                           &(*flags)[std::size_t(v) * width]);
  }
  return count;
}

namespace {

// Whether pixel u has fewer than `needed` close neighbours and a range: the rule itself.
inline bool flyingAt(const float* up, const float* mid, const float* down, int u, float base, float per_metre,
                     int needed) {
  const float r = mid[u], gap = base + per_metre * r;
  const int close = (std::abs(up[u - 1] - r) <= gap) + (std::abs(up[u] - r) <= gap) + (std::abs(up[u + 1] - r) <= gap) +
                    (std::abs(mid[u - 1] - r) <= gap) + (std::abs(mid[u + 1] - r) <= gap) +
                    (std::abs(down[u - 1] - r) <= gap) + (std::abs(down[u] - r) <= gap) +
                    (std::abs(down[u + 1] - r) <= gap);
  return (close < needed) & (r == r);
}

}  // namespace

std::size_t flagFlyingRow(const float* up, const float* mid, const float* down, int width,
                          const FlyingPixelOptions& options, std::uint8_t* out) {
  std::fill_n(out, width, std::uint8_t{0});
  // The image's border rows and columns are kept: with fewer neighbours they would be judged by
  // another rule, and a mixed pixel there floats at the view's edge only.
  if (!options.enabled || !up || !down || width < 3) return 0;
  const float base = static_cast<float>(options.gap_base), per_metre = static_cast<float>(options.gap_per_metre);
  const int needed = options.min_neighbours;
  std::size_t count = 0;
  int u = 1;
#if defined(__SSE2__)
  // Four pixels at a time. Nearly every pixel lies on a surface, where its left and right
  // neighbours are both close: with two neighbours needed, that settles it, and the other six are
  // read only for the few blocks of four at a depth edge or a hole's rim. A pixel without a
  // range is never flying. Each comparison is the rule's own (|n - r| <= gap, false for NaN).
  const __m128 base4 = _mm_set1_ps(base), per_metre4 = _mm_set1_ps(per_metre);
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128i needed4 = _mm_set1_epi32(needed);
  const bool two_settle = needed <= 2;
  const auto close = [&](const float* n, __m128 r, __m128 gap) {
    return _mm_cmple_ps(_mm_andnot_ps(sign, _mm_sub_ps(_mm_loadu_ps(n), r)), gap);
  };
  for (; u + 4 < width; u += 4) {
    const __m128 r = _mm_loadu_ps(mid + u);
    const __m128 gap = _mm_add_ps(base4, _mm_mul_ps(per_metre4, r));
    const __m128 left = close(mid + u - 1, r, gap), right = close(mid + u + 1, r, gap);
    const int settled = two_settle ? _mm_movemask_ps(_mm_and_ps(left, right)) : 0;
    if (settled == 0xF) continue;
    const __m128 no_range = _mm_cmpunord_ps(r, r);
    if ((settled | _mm_movemask_ps(no_range)) == 0xF) continue;
    // The count: each close neighbour's mask is -1.
    __m128i n = _mm_add_epi32(_mm_castps_si128(left), _mm_castps_si128(right));
    for (const float* row : {up, down}) {
      n = _mm_add_epi32(n, _mm_castps_si128(close(row + u - 1, r, gap)));
      n = _mm_add_epi32(n, _mm_castps_si128(close(row + u, r, gap)));
      n = _mm_add_epi32(n, _mm_castps_si128(close(row + u + 1, r, gap)));
    }
    const __m128i few = _mm_cmpgt_epi32(needed4, _mm_sub_epi32(_mm_setzero_si128(), n));
    const int flying = _mm_movemask_ps(_mm_andnot_ps(no_range, _mm_castsi128_ps(few)));
    for (int k = 0; k < 4; ++k) {
      out[u + k] = static_cast<std::uint8_t>((flying >> k) & 1);
      count += out[u + k];
    }
  }
#endif
  for (; u + 1 < width; ++u) {
    out[u] = flyingAt(up, mid, down, u, base, per_metre, needed);
    count += out[u];
  }
  return count;
}

}  // namespace octo_slice_mapper
