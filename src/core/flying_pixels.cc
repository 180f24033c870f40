#include "octo_slice_mapper/internal/flying_pixels.h"

#include <cmath>

namespace octo_slice_mapper {

std::size_t flagFlyingPixels(const std::vector<Eigen::Vector3f>& organized, int width, int height,
                             const FlyingPixelOptions& options, std::vector<std::uint8_t>* flags) {
  flags->clear();
  if (!options.enabled || width < 3 || height < 3 || organized.size() != std::size_t(width) * height) return 0;
  flags->assign(organized.size(), 0);
  // Ranges once (NaN stays NaN: it is close to nothing).
  std::vector<float> range(organized.size());
  const float* xyz = organized.data()->data();  // Eigen::Vector3f is three packed floats
  for (std::size_t i = 0; i < organized.size(); ++i) {
    const float x = xyz[3 * i], y = xyz[3 * i + 1], z = xyz[3 * i + 2];
    range[i] = std::sqrt(x * x + y * y + z * z);
  }
  const float base = static_cast<float>(options.gap_base), per_metre = static_cast<float>(options.gap_per_metre);
  const int needed = options.min_neighbours;
  // The image's border rows and columns are kept: with fewer neighbours they would be judged by
  // another rule, and a mixed pixel there floats at the view's edge only.
  for (int v = 1; v + 1 < height; ++v) {
    const float* up = &range[std::size_t(v - 1) * width];
    const float* mid = up + width;
    const float* down = mid + width;
    std::uint8_t* out = &(*flags)[std::size_t(v) * width];
    // Branch-free per pixel, so that the compiler can take several at a time.
    for (int u = 1; u + 1 < width; ++u) {
      const float r = mid[u], gap = base + per_metre * r;
      const int close = (std::abs(up[u - 1] - r) <= gap) + (std::abs(up[u] - r) <= gap) +
                        (std::abs(up[u + 1] - r) <= gap) + (std::abs(mid[u - 1] - r) <= gap) +
                        (std::abs(mid[u + 1] - r) <= gap) + (std::abs(down[u - 1] - r) <= gap) +
                        (std::abs(down[u] - r) <= gap) + (std::abs(down[u + 1] - r) <= gap);
      out[u] = static_cast<std::uint8_t>((close < needed) & (r == r));
    }
  }
  std::size_t count = 0;
  for (std::uint8_t f : *flags) count += f;
  return count;
}

}  // namespace octo_slice_mapper
