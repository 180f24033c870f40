#include "octo_slice_mapper/internal/flying_pixels.h"

#include <algorithm>
#include <cmath>

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
  // Branch-free per pixel, so that the compiler takes several at a time (-O3: CMakeLists.txt).
  for (int u = 1; u + 1 < width; ++u) {
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
