#include "octo_slice_mapper/internal/key_box.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

using namespace octo_slice_mapper;

namespace {
// The coordinates that decide a floor: random ones, every voxel boundary near the origin and the
// doubles on either side of it, and the tree's outermost voxels.
std::vector<double> coordinatesFor(double resolution, std::mt19937* rng) {
  std::vector<double> c;
  std::uniform_real_distribution<double> any(-120.0, 120.0);
  for (int i = 0; i < 20000; ++i) c.push_back(any(*rng));
  for (int k = -400; k <= 400; ++k) {
    const double boundary = k * resolution;
    c.push_back(boundary);
    c.push_back(std::nextafter(boundary, -1e9));
    c.push_back(std::nextafter(boundary, 1e9));
  }
  const double half_extent = resolution * 32768;
  for (const double edge : {half_extent, -half_extent, half_extent - resolution, -half_extent + resolution}) {
    for (double v = edge, step = 0; step < 8; ++step) {
      c.push_back(v);
      c.push_back(-v);
      v = std::nextafter(v, 0.0);
    }
  }
  return c;
}
}  // namespace

// The inline conversion gives OctoMap's key wherever it gives one, refuses what OctoMap refuses
// (and the tree's outermost boundary, -resolution x 32768, which its range check leaves out), and
// what lies outside the tree (where OctoMap's cast would be undefined behaviour).
TEST(KeyBox, CoordToKeySafeIsOctoMapsKeyInsideAndRefusesOutside) {
  std::mt19937 rng(17);
  std::size_t checked = 0, refused = 0;
  for (const double resolution : {0.05, 0.1, 0.013, 0.2}) {
    const octomap::OcTree tree(resolution);
    for (const double c : coordinatesFor(resolution, &rng)) {
      octomap::OcTreeKey mine, theirs;
      const bool ok = coordToKeySafe(tree, c, -c * 0.7, c * 0.3, &mine);
      const bool octomap_ok = tree.coordToKeyChecked(c, -c * 0.7, c * 0.3, theirs);
      if (ok) {
        ASSERT_TRUE(octomap_ok) << "resolution " << resolution << ", coordinate " << c;
        ASSERT_EQ(mine, theirs) << "resolution " << resolution << ", coordinate " << c;
      } else if (octomap_ok) {  // only the tree's outermost boundary itself, which the range check excludes
        ASSERT_EQ(std::abs(c), resolution * 32768) << "resolution " << resolution << ", coordinate " << c;
      }
      ++checked;
      refused += !ok;
    }
    octomap::OcTreeKey key;
    for (const double outside : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                                 -std::numeric_limits<double>::infinity(), 1e308, -3e38, resolution * 32768 * 2.5}) {
      EXPECT_FALSE(coordToKeySafe(tree, outside, 0.0, 0.0, &key)) << outside;
      EXPECT_FALSE(coordToKeySafe(tree, 0.0, 0.0, outside, &key)) << outside;
    }
  }
  EXPECT_GT(checked, 80000u);
  EXPECT_GT(refused, 10u) << "the tree's edges were reached";
}

// The box of a list of keys (eight at a time where there are eight) is the one key-by-key adds
// give: for every count up to 40 and for counts above 1 000, random keys anywhere in the 16-bit
// range or around its top bit (where signed and unsigned order differ), some with 0 and 0xFFFF on
// a random axis: so an axis's extreme falls in every lane of the eight-key rounds and in the rest.
TEST(KeyBox, OfIsTheBoxOfEveryKey) {
  std::mt19937 rng(43);
  std::uniform_int_distribution<int> word(0, 0xFFFF), near_top(0x7FF0, 0x8010);
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t n = trial < 240 ? std::size_t(trial % 41) : std::size_t(1000 + trial);
    std::vector<octomap::OcTreeKey> keys;
    for (std::size_t i = 0; i < n; ++i) {
      const bool narrow = trial % 3 == 1;  // around the top bit only
      octomap::OcTreeKey k;
      for (int d = 0; d < 3; ++d) k[d] = static_cast<octomap::key_type>(narrow ? near_top(rng) : word(rng));
      keys.push_back(k);
    }
    if (n > 0 && trial % 5 == 0) {  // the range's ends, at a random key and axis
      keys[rng() % n][rng() % 3] = 0;
      keys[rng() % n][rng() % 3] = 0xFFFF;
    }
    KeyBox expected;
    for (const octomap::OcTreeKey& k : keys) expected.add(k);
    const KeyBox box = KeyBox::of(keys);
    EXPECT_EQ(box.empty(), keys.empty());
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(box.min[d], expected.min[d]) << "axis " << d << ", " << n << " keys, trial " << trial;
      ASSERT_EQ(box.max[d], expected.max[d]) << "axis " << d << ", " << n << " keys, trial " << trial;
    }
  }
}
