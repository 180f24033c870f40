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
  // Four pixels at a time. Most pixels lie on a surface with both row neighbours close: when
  // those two already reach min_neighbours for all four, the other six are not looked at.
  const __m128 vbase = _mm_set1_ps(base), vper = _mm_set1_ps(per_metre), one = _mm_set1_ps(1.0f);
  const __m128 vneeded = _mm_set1_ps(static_cast<float>(needed));
  const __m128 sign = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const auto close = [&](const float* n, __m128 r, __m128 gap) {  // 1.0f where |n - r| <= gap, else 0
    return _mm_and_ps(_mm_cmple_ps(_mm_and_ps(_mm_sub_ps(_mm_loadu_ps(n), r), sign), gap), one);
  };
  for (; u + 4 < width; u += 4) {
    const __m128 r = _mm_loadu_ps(mid + u);
    const __m128 gap = _mm_add_ps(vbase, _mm_mul_ps(vper, r));
    __m128 n = _mm_add_ps(close(mid + u - 1, r, gap), close(mid + u + 1, r, gap));
    const __m128 measured = _mm_cmpord_ps(r, r);  // NaN (no measurement) is never flagged
    if (_mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(n, vneeded), measured)) == 0) continue;  // all four kept
    n = _mm_add_ps(n, _mm_add_ps(close(up + u - 1, r, gap), close(up + u, r, gap)));
    n = _mm_add_ps(n, _mm_add_ps(close(up + u + 1, r, gap), close(down + u - 1, r, gap)));
    n = _mm_add_ps(n, _mm_add_ps(close(down + u, r, gap), close(down + u + 1, r, gap)));
    const int flying = _mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(n, vneeded), measured));
    for (int k = 0; k < 4; ++k) {
      out[u + k] = static_cast<std::uint8_t>((flying >> k) & 1);
      count += (flying >> k) & 1;
    }
  }
#endif
  for (; u + 1 < width; ++u) {
    const float r = mid[u], gap = base + per_metre * r;
    const int close = (std::abs(up[u - 1] - r) <= gap) + (std::abs(up[u] - r) <= gap) +
                      (std::abs(up[u + 1] - r) <= gap) + (std::abs(mid[u - 1] - r) <= gap) +
                      (std::abs(mid[u + 1] - r) <= gap) + (std::abs(down[u - 1] - r) <= gap) +
                      (std::abs(down[u] - r) <= gap) + (std::abs(down[u + 1] - r) <= gap);
    out[u] = static_cast<std::uint8_t>((close < needed) & (r == r));
    count += out[u];
  }
  return count;
}

}  // namespace octo_slice_mapper
