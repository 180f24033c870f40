// Flying pixels: a depth camera's mixed pixels at depth edges, which read a depth between the
// edge and what lies behind it and so float in free air. Found in the organized frame: a pixel
// is flying when it is close in range to fewer than min_neighbours of its eight neighbours (it
// stands alone), or when it lies between two opposite neighbours (left and right, or above and
// below), nearer than one and farther than the other by more than the close gap, and off the
// straight surface through them by more than the gap too (a chain of mixed pixels along an edge,
// close to each other). A surface's pixel has its neighbours along the surface, and at an edge on
// the side of the surface it belongs to; a surface seen so obliquely that its rows step by more
// than the gap (a floor far from a low or coarse camera) lies on the straight surface through
// its neighbours.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace octo_slice_mapper {

struct FlyingPixelOptions {
  bool enabled = true;
  // A neighbour is close when its range differs by at most gap_base + gap_per_metre * range (m):
  // at 4 m, 0.15 m, wider than a Kinect's noise (3 sigma: 8 cm) and a floor's step from one
  // pixel row to the next at a grazing angle.
  double gap_base = 0.03;
  double gap_per_metre = 0.03;
  int min_neighbours = 2;
};

// Flags (1 in `flags`, resized to width x height) the flying pixels of an organized frame (row by
// row, in the sensor's frame, NaN where no depth) and returns how many. Nothing is flagged when
// the frame is not organized (width x height != size) or the filter is off.
std::size_t flagFlyingPixels(const std::vector<Eigen::Vector3f>& organized, int width, int height,
                             const FlyingPixelOptions& options, std::vector<std::uint8_t>* flags);

// The same a row at a time, for a caller that streams a frame through a few rows of memory:
// one row's flags (`width` bytes) from its ranges (sqrt(x^2 + y^2 + z^2) in the sensor frame;
// NaN where no depth) and its neighbours' (null above the first or below the last row: that row
// is kept). Returns the row's flying pixels.
std::size_t flagFlyingRow(const float* up, const float* row, const float* down, int width,
                          const FlyingPixelOptions& options, std::uint8_t* flags);

}  // namespace octo_slice_mapper
