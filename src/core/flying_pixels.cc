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

// Whether the range r lies beyond the gap between a and b, nearer than one and farther than the
// other, and off the straight surface through them by more than the gap (false where either has
// no range). A plane's ranges at evenly spaced rays have 1 / range linear, so a surface seen
// obliquely, whose rows step by more than the gap, lies at the harmonic mean of its neighbours.
inline bool between(float a, float b, float r, float gap) {
  const bool across = (a < r - gap && b > r + gap) || (a > r + gap && b < r - gap);
  // |r - 2 a b / (a + b)| > gap, without the division.
  return across && std::abs(r * (a + b) - 2.0f * a * b) > gap * (a + b);
}

// Whether pixel u has a range and is flying: fewer than `needed` close neighbours, or between
// its left and right or its upper and lower neighbours. The rule itself.
inline bool flyingAt(const float* up, const float* mid, const float* down, int u, float base, float per_metre,
                     int needed) {
  const float r = mid[u], gap = base + per_metre * r;
  const int close = (std::abs(up[u - 1] - r) <= gap) + (std::abs(up[u] - r) <= gap) + (std::abs(up[u + 1] - r) <= gap) +
                    (std::abs(mid[u - 1] - r) <= gap) + (std::abs(mid[u + 1] - r) <= gap) +
                    (std::abs(down[u - 1] - r) <= gap) + (std::abs(down[u] - r) <= gap) +
                    (std::abs(down[u + 1] - r) <= gap);
  const bool lone = close < needed;
  return (lone | between(mid[u - 1], mid[u + 1], r, gap) | between(up[u], down[u], r, gap)) & (r == r);
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
  // Four pixels at a time. Nearly every pixel lies on a surface, where its left, right and upper
  // neighbours are all close: that settles it (three close, and between neither pair), and the
  // other five are read only for the few blocks of four at a depth edge or a hole's rim. A pixel
  // without a range is never flying. Each comparison is the rule's own (false for NaN).
  const __m128 base4 = _mm_set1_ps(base), per_metre4 = _mm_set1_ps(per_metre);
  const __m128 sign = _mm_set1_ps(-0.0f);
  const __m128i needed4 = _mm_set1_epi32(needed);
  const bool three_settle = needed <= 3;
  const auto close = [&](const float* n, __m128 r, __m128 gap) {
    return _mm_cmple_ps(_mm_andnot_ps(sign, _mm_sub_ps(_mm_loadu_ps(n), r)), gap);
  };
  // between() four at a time (nearer = r - gap, farther = r + gap).
  const auto between4 = [&](__m128 a, __m128 b, __m128 r, __m128 gap, __m128 nearer, __m128 farther) {
    const __m128 across = _mm_or_ps(_mm_and_ps(_mm_cmplt_ps(a, nearer), _mm_cmpgt_ps(b, farther)),
                                    _mm_and_ps(_mm_cmpgt_ps(a, farther), _mm_cmplt_ps(b, nearer)));
    const __m128 sum = _mm_add_ps(a, b);
    const __m128 off = _mm_andnot_ps(sign, _mm_sub_ps(_mm_mul_ps(r, sum), _mm_mul_ps(_mm_set1_ps(2.0f), _mm_mul_ps(a, b))));
    return _mm_and_ps(across, _mm_cmpgt_ps(off, _mm_mul_ps(gap, sum)));
  };
  for (; u + 4 < width; u += 4) {
    const __m128 r = _mm_loadu_ps(mid + u);
    const __m128 gap = _mm_add_ps(base4, _mm_mul_ps(per_metre4, r));
    const __m128 left = close(mid + u - 1, r, gap), right = close(mid + u + 1, r, gap);
    const __m128 above = close(up + u, r, gap);
    const int settled = three_settle ? _mm_movemask_ps(_mm_and_ps(_mm_and_ps(left, right), above)) : 0;
    if (settled == 0xF) continue;
    const __m128 no_range = _mm_cmpunord_ps(r, r);
    if ((settled | _mm_movemask_ps(no_range)) == 0xF) continue;
    // The count: each close neighbour's mask is -1.
    __m128i n = _mm_add_epi32(_mm_add_epi32(_mm_castps_si128(left), _mm_castps_si128(right)), _mm_castps_si128(above));
    n = _mm_add_epi32(n, _mm_castps_si128(close(up + u - 1, r, gap)));
    n = _mm_add_epi32(n, _mm_castps_si128(close(up + u + 1, r, gap)));
    for (int du = -1; du <= 1; ++du) n = _mm_add_epi32(n, _mm_castps_si128(close(down + u + du, r, gap)));
    const __m128 few = _mm_castsi128_ps(_mm_cmpgt_epi32(needed4, _mm_sub_epi32(_mm_setzero_si128(), n)));
    const __m128 nearer = _mm_sub_ps(r, gap), farther = _mm_add_ps(r, gap);
    const __m128 across =
        _mm_or_ps(between4(_mm_loadu_ps(mid + u - 1), _mm_loadu_ps(mid + u + 1), r, gap, nearer, farther),
                  between4(_mm_loadu_ps(up + u), _mm_loadu_ps(down + u), r, gap, nearer, farther));
    const int flying = _mm_movemask_ps(_mm_andnot_ps(no_range, _mm_or_ps(few, across)));
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
