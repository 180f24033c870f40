// Flying pixels: a depth edge's mixed pixels are flagged, alone or in a chain along the edge;
// surfaces, their edges and corners, grazing floors (also where their rows step by more than the
// gap), thin structures and pixels without depth are not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "octo_slice_mapper/internal/flying_pixels.h"

using namespace octo_slice_mapper;

namespace {

constexpr int kW = 64, kH = 48;
const float kNaN = std::numeric_limits<float>::quiet_NaN();

// An organized frame of depths (optical frame: the point is the pixel's ray times its depth).
std::vector<Eigen::Vector3f> frameOf(const std::vector<float>& depth) {
  std::vector<Eigen::Vector3f> points(depth.size());
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      const Eigen::Vector3f ray((u - kW / 2) / 500.0f, (v - kH / 2) / 500.0f, 1.0f);
      points[std::size_t(v) * kW + u] = ray * depth[std::size_t(v) * kW + u];
    }
  }
  return points;
}

}  // namespace

TEST(FlyingPixels, AnEdgesMixedPixelsAreFlaggedAndTheSurfacesAreNot) {
  // A box at 1.5 m before a wall at 4 m (columns 20-39), its left edge's column mixed.
  std::vector<float> depth(kW * kH, 4.0f);
  for (int v = 0; v < kH; ++v) {
    for (int u = 20; u < 40; ++u) depth[std::size_t(v) * kW + u] = 1.5f;
    depth[std::size_t(v) * kW + 19] = (v % 2) ? 2.3f : 3.1f;  // between the two, no two alike
  }
  std::vector<std::uint8_t> flags;
  const std::size_t count = flagFlyingPixels(frameOf(depth), kW, kH, {}, &flags);
  ASSERT_EQ(flags.size(), std::size_t(kW * kH));
  for (int v = 1; v + 1 < kH; ++v) {
    EXPECT_EQ(flags[std::size_t(v) * kW + 19], 1) << v;
    for (int u = 1; u + 1 < kW; ++u) {
      if (u != 19) {
        EXPECT_EQ(flags[std::size_t(v) * kW + u], 0) << u << " " << v;
      }
    }
  }
  EXPECT_EQ(count, std::size_t(kH - 2));
}

// Mixed pixels along an edge whose ranges lie close to each other: each has its two neighbours
// in the chain close (which a count of close neighbours alone lets through), and lies between
// the near surface and the far one.
TEST(FlyingPixels, AChainOfMixedPixelsAlongAnEdgeIsFlagged) {
  // A table top at 2.0 m (rows 0-19) before the floor behind at 2.6 m; row 20, the top's edge,
  // mixed, its ranges within a centimetre of each other. And a box at 1.5 m before a wall at
  // 3.0 m (columns 40-63 of rows 30-47), its left column mixed likewise. Neither chain lies on a
  // straight surface from the near side to the far one (the two sides' harmonic mean).
  std::vector<float> depth(kW * kH, 2.6f);
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < kW; ++u) depth[std::size_t(v) * kW + u] = 2.0f;
  }
  for (int u = 0; u < kW; ++u) depth[std::size_t(20) * kW + u] = 2.45f + 0.01f * (u % 2);
  for (int v = 30; v < kH; ++v) {
    for (int u = 40; u < kW; ++u) depth[std::size_t(v) * kW + u] = 1.5f;
    depth[std::size_t(v) * kW + 39] = 2.2f + 0.01f * (v % 2);
  }
  std::vector<std::uint8_t> flags;
  flagFlyingPixels(frameOf(depth), kW, kH, {}, &flags);
  for (int u = 1; u + 1 < kW; ++u) EXPECT_EQ(flags[std::size_t(20) * kW + u], 1) << "table edge, column " << u;
  for (int v = 31; v + 1 < kH; ++v) EXPECT_EQ(flags[std::size_t(v) * kW + 39], 1) << "box edge, row " << v;
  // The surfaces' own pixels, their edges and the box's corner pixel among them, are kept.
  for (int v = 1; v + 1 < kH; ++v) {
    for (int u = 1; u + 1 < kW; ++u) {
      if (v != 20 && !(u == 39 && v >= 30)) {
        EXPECT_EQ(flags[std::size_t(v) * kW + u], 0) << u << " " << v;
      }
    }
  }
}

TEST(FlyingPixels, AGrazingFloorAOnePixelPoleAndPixelsWithoutDepthAreKept) {
  std::vector<float> depth(kW * kH, kNaN);
  // A floor seen at a grazing angle: depth grows fast from row to row (4 m ... 1.6 m, 5 cm a row).
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) depth[std::size_t(v) * kW + u] = 4.0f - 0.05f * v;
  }
  // A pole one pixel wide at 1 m, and a hole without depth.
  for (int v = 0; v < kH; ++v) depth[std::size_t(v) * kW + 30] = 1.0f;
  for (int u = 40; u < 45; ++u) depth[std::size_t(10) * kW + u] = kNaN;
  std::vector<std::uint8_t> flags;
  EXPECT_EQ(flagFlyingPixels(frameOf(depth), kW, kH, {}, &flags), 0u);
}

// A surface seen so obliquely that its ranges step by more than the gap from one pixel row to the
// next (a floor far from a low camera, a coarse camera's floor) lies between its neighbours above
// and below, but on the straight surface through them: kept. A pixel off that surface is flagged.
TEST(FlyingPixels, AnObliqueSurfacesPixelBetweenItsNeighboursIsKept) {
  const int width = 9;
  // A plane's ranges at evenly spaced rays: 1 / range linear (5 m in the middle row, rows 0.5 m apart).
  std::vector<float> up(width, 1.0f / 0.18f), mid(width, 1.0f / 0.2f), down(width, 1.0f / 0.22f);
  std::vector<std::uint8_t> flags(width);
  FlyingPixelOptions options;
  const float gap = float(options.gap_base) + float(options.gap_per_metre) * mid[4];
  ASSERT_GT(up[4] - mid[4], gap);
  ASSERT_GT(mid[4] - down[4], gap);
  EXPECT_EQ(flagFlyingRow(up.data(), mid.data(), down.data(), width, options, flags.data()), 0u);
  // The middle row 0.3 m off the plane, still between the rows above and below (a chain of mixed
  // pixels): each is flagged, but for the border columns.
  std::fill(mid.begin(), mid.end(), 5.3f);
  EXPECT_EQ(flagFlyingRow(up.data(), mid.data(), down.data(), width, options, flags.data()), std::size_t(width - 2));
}

TEST(FlyingPixels, OffOrNotOrganizedFlagsNothing) {
  std::vector<float> depth(kW * kH, 4.0f);
  depth[20 * kW + 20] = 2.0f;  // one lone pixel
  std::vector<std::uint8_t> flags;
  EXPECT_EQ(flagFlyingPixels(frameOf(depth), kW, kH, {}, &flags), 1u);
  FlyingPixelOptions off;
  off.enabled = false;
  EXPECT_EQ(flagFlyingPixels(frameOf(depth), kW, kH, off, &flags), 0u);
  EXPECT_TRUE(flags.empty());
  EXPECT_EQ(flagFlyingPixels(frameOf(depth), kW * kH, 1, {}, &flags), 0u);  // an unorganized cloud
}

// The row judge flags exactly what the rule says, pixel by pixel, for one, two, three and four
// neighbours needed, in a row whose length is not a multiple of a vector's: random ranges with
// depth edges, noise and holes; and smooth surfaces with a rare edge, hole or lone pixel (where
// most pixels are settled by their left, right and upper neighbours).
TEST(FlyingPixels, TheRowJudgeFlagsExactlyWhatTheRuleSays) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const int width = 71;
  std::vector<float> rows(3 * width);
  for (int trial = 0; trial < 600; ++trial) {
    const bool smooth = trial >= 300;
    float surface = 1.0f + 3.0f * unit(rng);
    for (float& r : rows) {
      const float x = unit(rng);
      if (smooth) {
        if (x < 0.02f) surface = 1.0f + 3.0f * unit(rng);  // a depth edge
        r = x > 0.99f ? kNaN : x > 0.98f ? 0.5f + 4.0f * unit(rng) : surface + 0.01f * unit(rng);
      } else {
        r = x < 0.05f ? kNaN : x < 0.5f ? 1.5f + 0.01f * unit(rng) : x < 0.8f ? 3.0f + 0.05f * unit(rng) : 0.5f + 4.0f * unit(rng);
      }
    }
    FlyingPixelOptions options;
    options.min_neighbours = 1 + trial % 4;
    const float* up = rows.data();
    const float* mid = up + width;
    const float* down = mid + width;
    std::vector<std::uint8_t> flags(width, 7);
    const std::size_t count = flagFlyingRow(up, mid, down, width, options, flags.data());
    std::size_t expected_count = 0;
    for (int u = 0; u < width; ++u) {
      bool flying = false;
      if (u > 0 && u + 1 < width && !std::isnan(mid[u])) {
        const float gap = float(options.gap_base) + float(options.gap_per_metre) * mid[u];
        int close = 0;
        for (const float* row : {up, mid, down}) {
          for (int du = -1; du <= 1; ++du) {
            if (row == mid && du == 0) continue;
            close += std::abs(row[u + du] - mid[u]) <= gap;
          }
        }
        // Between two opposite neighbours: nearer than one and farther than the other, beyond the
        // gap, and off the straight surface through them (their harmonic mean) by more than it.
        const auto between = [&](float a, float b) {
          const bool across = (a < mid[u] - gap && b > mid[u] + gap) || (a > mid[u] + gap && b < mid[u] - gap);
          return across && std::abs(mid[u] * (a + b) - 2.0f * a * b) > gap * (a + b);
        };
        flying = close < options.min_neighbours || between(mid[u - 1], mid[u + 1]) || between(up[u], down[u]);
      }
      expected_count += flying;
      ASSERT_EQ(flags[u], flying ? 1 : 0) << "trial " << trial << ", pixel " << u;
    }
    EXPECT_EQ(count, expected_count);
  }
}
