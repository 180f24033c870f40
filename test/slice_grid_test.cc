#include "octo_slice_mapper/slice_grid.h"

#include <gtest/gtest.h>

#include <cmath>

#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

KeyBox boxAround(const octomap::OcTree& tree, double x, double y, double z) {
  KeyBox box;
  box.add(tree.coordToKey(x, y, z));
  return box;
}

}  // namespace

TEST(SliceGrid, RespectsTheZBand) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{0.16, 0.36});
  tree.updateNode(1.0, 1.0, 0.26, 2.0f);   // obstacle at laser height
  tree.updateNode(2.0, 1.0, 1.00, 2.0f);   // shelf above the band
  tree.updateNode(3.0, 1.0, 0.02, 2.0f);   // cable below the band
  KeyBox box = boxAround(tree, 1.0, 1.0, 0.26);
  box.add(boxAround(tree, 2.0, 1.0, 1.0));
  box.add(boxAround(tree, 3.0, 1.0, 0.02));
  slice.update(box);
  EXPECT_GT(slice.valueAt(1.0, 1.0), 80);
  EXPECT_EQ(slice.valueAt(2.0, 1.0), kUnknownCell);
  EXPECT_EQ(slice.valueAt(3.0, 1.0), kUnknownCell);
}

TEST(SliceGrid, HoldsProbabilitiesNotJustThreeValues) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{});
  tree.updateNode(0.5, 0.5, 0.26, 0.4f);
  tree.updateNode(0.7, 0.5, 0.26, -0.4f);
  tree.updateNode(0.9, 0.5, 0.26, 0.0f);
  KeyBox box = boxAround(tree, 0.5, 0.5, 0.26);
  box.add(boxAround(tree, 0.9, 0.5, 0.26));
  slice.update(box);
  EXPECT_EQ(slice.valueAt(0.5, 0.5), std::lround(100.0 / (1.0 + std::exp(-0.4))));
  EXPECT_EQ(slice.valueAt(0.7, 0.5), std::lround(100.0 / (1.0 + std::exp(0.4))));
  EXPECT_EQ(slice.valueAt(0.9, 0.5), 50);
  EXPECT_EQ(slice.valueAt(0.6, 0.5), kUnknownCell);
  for (std::int8_t v : slice.data()) EXPECT_TRUE(v == kUnknownCell || (v >= 0 && v <= 100));
}

TEST(SliceGrid, MostOccupiedVoxelOfTheColumnCounts) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{0.16, 0.36});
  tree.updateNode(1.0, 1.0, 0.21, -1.0f);
  tree.updateNode(1.0, 1.0, 0.31, 1.5f);
  KeyBox box = boxAround(tree, 1.0, 1.0, 0.21);
  box.add(boxAround(tree, 1.0, 1.0, 0.31));
  slice.update(box);
  EXPECT_EQ(slice.valueAt(1.0, 1.0), std::lround(100.0 / (1.0 + std::exp(-1.5))));
}

// Without an obstacle in any layer, a column is as free as its best-observed layer: weak evidence
// in a layer a tilted beam only grazed (45 %) must not hide the free layer it crossed.
TEST(SliceGrid, WithoutAnObstacleTheFreestLayerCounts) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{0.16, 0.36});
  tree.updateNode(1.0, 1.0, 0.21, -0.2f);  // grazed: 45 %
  tree.updateNode(1.0, 1.0, 0.31, -2.0f);  // crossed: 12 %
  KeyBox box = boxAround(tree, 1.0, 1.0, 0.21);
  box.add(boxAround(tree, 1.0, 1.0, 0.31));
  slice.update(box);
  EXPECT_EQ(slice.valueAt(1.0, 1.0), std::lround(100.0 / (1.0 + std::exp(2.0))));
  tree.updateNode(1.0, 1.0, 0.21, 0.5f);  // now 57 % occupied: an obstacle there blocks the column
  slice.update(box);
  EXPECT_EQ(slice.valueAt(1.0, 1.0), std::lround(100.0 / (1.0 + std::exp(-0.3))));
}

TEST(SliceGrid, IncrementalUpdatesEqualAFullRebuild) {
  MapperOptions options;
  Mapper mapper(options);
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  std::mt19937 rng(7);
  const auto times = session.scanTimes();
  for (std::size_t i = 0; i < times.size() && i < 400; i += 2) ASSERT_TRUE(mapper.insert(session.scanAt(times[i], &rng)).ok());

  SliceGrid rebuilt(mapper.tree(), options.slice);
  rebuilt.rebuild();
  const SliceGrid& live = mapper.slice();
  ASSERT_GT(live.knownCells(), 1000u);
  EXPECT_EQ(live.knownCells(), rebuilt.knownCells());
  std::size_t compared = 0;
  for (int j = 0; j < live.height(); ++j) {
    for (int i = 0; i < live.width(); ++i) {
      const int kx = live.originKeyX() + i, ky = live.originKeyY() + j;
      const int ri = kx - rebuilt.originKeyX(), rj = ky - rebuilt.originKeyY();
      const bool in_rebuilt = ri >= 0 && rj >= 0 && ri < rebuilt.width() && rj < rebuilt.height();
      const std::int8_t expected = in_rebuilt ? rebuilt.at(ri, rj) : kUnknownCell;
      ASSERT_EQ(live.at(i, j), expected) << "cell key (" << kx << ", " << ky << ")";
      ++compared;
    }
  }
  EXPECT_GT(compared, 10000u);
}

TEST(SliceGrid, GrowsWithoutLosingCells) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{});
  tree.updateNode(0.0, 0.0, 0.26, 1.0f);
  slice.update(boxAround(tree, 0.0, 0.0, 0.26));
  const std::int8_t before = slice.valueAt(0.0, 0.0);
  tree.updateNode(-30.0, 25.0, 0.26, -1.0f);
  slice.update(boxAround(tree, -30.0, 25.0, 0.26));
  EXPECT_EQ(slice.valueAt(0.0, 0.0), before);
  EXPECT_NE(slice.valueAt(-30.0, 25.0), kUnknownCell);
}

// The slice skips band layers nothing has reached. A layer that a point cloud reaches later, or
// that a loaded map already holds, must count from then on, also where a level scan then changes
// the column through its own layer.
TEST(SliceGrid, ALayerReachedLaterOrLoadedStillCounts) {
  const double low_z = 0.185;  // another layer of the band than the laser's (0.26 m)
  // An obstacle at low_z only, in the middle of what the laser sees free.
  auto obstacle = [&](Mapper* mapper) {
    std::vector<Eigen::Vector3f> points;
    for (int k = -2; k <= 2; ++k) points.emplace_back(1.5f, 0.05f * k, float(low_z));
    for (int n = 0; n < 5; ++n) ASSERT_TRUE(mapper->insertPoints(Eigen::Vector3d(0.0, 0.0, low_z), points).ok());
  };
  auto level_scan = [] {  // straight ahead to a wall at 3 m, through (1.5, 0)
    return test_support::makeScan(test_support::laserPoseOnRobot(-0.1, 0.0, 0.0), -0.2f, 0.01f,
                                  std::vector<float>(41, 3.0f));
  };
  auto expect_matches_rebuild = [](Mapper& mapper) {
    SliceGrid rebuilt(mapper.tree(), mapper.options().slice);
    rebuilt.rebuild();
    const SliceGrid& live = mapper.slice();
    ASSERT_EQ(live.knownCells(), rebuilt.knownCells());
    for (double x = 0.0; x < 3.2; x += 0.05) {
      for (double y = -0.5; y < 0.5; y += 0.05) ASSERT_EQ(live.valueAt(x, y), rebuilt.valueAt(x, y)) << x << ", " << y;
    }
  };

  Mapper mapper;
  for (int n = 0; n < 3; ++n) ASSERT_TRUE(mapper.insert(level_scan()).ok());
  ASSERT_LT(mapper.slice().valueAt(1.5, 0.0), 50) << "the laser's layer sees it free";
  obstacle(&mapper);
  EXPECT_GT(mapper.slice().valueAt(1.5, 0.0), 50) << "the low layer's obstacle counts";
  ASSERT_TRUE(mapper.insert(level_scan()).ok());  // changes the column through the laser's layer
  EXPECT_GT(mapper.slice().valueAt(1.5, 0.0), 50) << "and still counts after the next scan";
  expect_matches_rebuild(mapper);

  // The same map saved and loaded: the low layer is known from the file.
  char tmpl[] = "/tmp/osm_slice_XXXXXX";
  const std::string path = std::string(::mkdtemp(tmpl)) + "/map.ot";
  std::string error;
  ASSERT_TRUE(saveFullTree(mapper.tree(), path, &error)) << error;
  Mapper resumed;
  ASSERT_TRUE(resumed.load(path, &error)) << error;
  EXPECT_GT(resumed.slice().valueAt(1.5, 0.0), 50);
  ASSERT_TRUE(resumed.insert(level_scan()).ok());
  EXPECT_GT(resumed.slice().valueAt(1.5, 0.0), 50) << "a scan after loading keeps the loaded layer";
  expect_matches_rebuild(resumed);
}

// Loading a map whose band spans kilometres is refused with a reason instead of building a
// gigabyte slice for minutes (as half of an .ot can ask for); the map in place stays.
TEST(SliceGrid, ASliceTooBigToBuildIsRefusedOnLoad) {
  octomap::OcTree far_apart(0.05);
  far_apart.updateNode(-1500.0, -1500.0, 0.26, true);
  far_apart.updateNode(1500.0, 1500.0, 0.26, true);
  SliceGrid slice(far_apart, SliceOptions());
  EXPECT_THROW(slice.rebuild(), std::length_error);

  char tmpl[] = "/tmp/osm_slice_XXXXXX";
  const std::string path = std::string(::mkdtemp(tmpl)) + "/far.ot";
  std::string error;
  ASSERT_TRUE(saveFullTree(far_apart, path, &error)) << error;
  Mapper mapper;
  ASSERT_TRUE(mapper.insert(test_support::makeScan(test_support::laserPoseOnRobot(0.0, 0.0, 0.0), -0.2f, 0.01f,
                                                   std::vector<float>(41, 3.0f)))
                  .ok());
  const std::size_t known = mapper.slice().knownCells();
  EXPECT_FALSE(mapper.load(path, &error));
  EXPECT_NE(error.find("cells"), std::string::npos) << error;
  EXPECT_EQ(mapper.slice().knownCells(), known) << "the map in place is kept";
  EXPECT_DOUBLE_EQ(mapper.options().resolution, 0.05);
}

// Far apart but within the limit: only the leaves' columns are computed, and they are right.
TEST(SliceGrid, ASparseMapRebuildsItsLeavesColumns) {
  octomap::OcTree tree(0.05);
  for (int n = 0; n < 3; ++n) {
    tree.updateNode(-200.0, -200.0, 0.26, true);
    tree.updateNode(200.0, 200.0, 0.26, false);
  }
  SliceGrid slice(tree, SliceOptions());
  slice.rebuild();
  EXPECT_EQ(slice.knownCells(), 2u);
  EXPECT_GT(slice.valueAt(-200.0, -200.0), 50);
  EXPECT_LT(slice.valueAt(200.0, 200.0), 50);
  EXPECT_EQ(slice.valueAt(0.0, 0.0), kUnknownCell);
}

// A column follows most changes of its voxels from its own cell (updateColumns with the changes,
// columnAfter): random updates of a few columns' band layers through the layer cache, each batch
// checked against the same batch without the changes (every listed column read from its layers).
// The values run over the whole clamping range, so that every rule is taken, both signs, the 50 %
// boundary and voxels moving away from the extreme that counts.
// Random changes in a 4 x 4 patch of columns, followed from each change (updateColumns with the
// changes) and read again (without them): the same slice after every batch. With `shift`, the
// patch's even columns are shifted by it (a floor found off the band's), their bands read.
void expectColumnsFollowAsRead(int shift) {
  octomap::OcTree tree(0.05);
  tree.setClampingThresMin(0.003);
  tree.setClampingThresMax(0.997);
  LayerCache cache(&tree);
  SliceGrid followed(tree, SliceOptions{}, &cache), read(tree, SliceOptions{}, &cache);
  const unsigned lo = followed.bandMinKey(), hi = followed.bandMaxKey();
  ASSERT_GE(hi - lo, 3u) << "the default band holds several layers";
  const octomap::OcTreeKey origin = tree.coordToKey(1.0, 2.0, 0.26);
  std::vector<std::pair<std::uint32_t, int>> shifts;
  for (int dx = 0; shift != 0 && dx < 4; dx += 2) {
    for (int dy = 0; dy < 4; ++dy) shifts.emplace_back(std::uint32_t(origin[0] + dx) | std::uint32_t(origin[1] + dy) << 16, shift);
  }
  followed.shiftColumns(shifts);
  read.shiftColumns(shifts);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> column(0, 3), layer(int(lo) - 1 + std::min(0, shift), int(hi) + 1 + std::max(0, shift)),
      steps(-8, 8);
  const float step = 0.35f;  // a few steps cross 0 and reach the bounds (about +-5.8)
  std::size_t changes_seen = 0, in_band = 0, followed_alone = 0;
  for (int batch = 0; batch < 3000; ++batch) {
    std::vector<octomap::OcTreeKey> keys;
    std::vector<VoxelChange> changes;
    const int n = 1 + batch % 6;
    for (int u = 0; u < n; ++u) {
      const octomap::OcTreeKey key(origin[0] + column(rng), origin[1] + column(rng), std::uint16_t(layer(rng)));
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) continue;  // one change per voxel and batch
      LayerCache::Layer& l = cache.layer(key[2]);
      cache.cover(&l, key[0], key[1], key[0], key[1]);
      VoxelChange change;
      if (cache.apply(l, key[0], key[1], step * steps(rng), &change)) {
        const int kx = key[0] - read.originKeyX(), ky = key[1] - read.originKeyY();
        const bool covered = read.width() > 0 && kx >= 0 && ky >= 0 && kx < read.width() && ky < read.height();
        const int s = read.columnShift(key[0], key[1]);
        if (int(key[2]) >= int(lo) + s && int(key[2]) <= int(hi) + s && covered) {
          ++in_band;
          followed_alone += SliceGrid::columnAfter(read.at(kx, ky), change) != kPendingCell;
        }
        keys.push_back(key);
        changes.push_back(change);
      }
    }
    const KeyBox box = KeyBox::of(keys);
    followed.updateColumns(keys, box, changes);
    read.updateColumns(keys, box);
    changes_seen += keys.size();
    ASSERT_EQ(followed.data(), read.data()) << "batch " << batch << ", shift " << shift;
  }
  EXPECT_GT(changes_seen, 5000u);
  // Most changes in a column's band need no read (counted against each column's value before
  // its batch).
  EXPECT_GT(followed_alone, in_band / 2) << "shift " << shift;
  EXPECT_GT(read.knownCells(), 10u);
  cache.flush();  // a rebuild finds the columns through the octree's leaves
  SliceGrid rebuilt(tree, SliceOptions{});
  rebuilt.shiftColumns(shifts);
  rebuilt.rebuild();
  for (int dx = 0; dx < 4; ++dx) {
    for (int dy = 0; dy < 4; ++dy) {
      const double x = tree.keyToCoord(origin[0] + dx), y = tree.keyToCoord(origin[1] + dy);
      EXPECT_EQ(followed.valueAt(x, y), rebuilt.valueAt(x, y)) << dx << ", " << dy << ", shift " << shift;
    }
  }
}

TEST(SliceGrid, ColumnsFollowTheirChangesAsIfTheyWereRead) { expectColumnsFollowAsRead(0); }

TEST(SliceGrid, ShiftedColumnsFollowTheirChangesAsIfTheyWereRead) {
  expectColumnsFollowAsRead(3);
  expectColumnsFollowAsRead(-2);
}

TEST(SliceGrid, AShiftedColumnReadsItsOwnBandAndFollowsItsVoxels) {
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{0.05, 0.20});
  octomap::OcTreeKey a, b;
  ASSERT_TRUE(coordToKeySafe(tree, 1.025, 1.025, 0.325, &a));
  ASSERT_TRUE(coordToKeySafe(tree, 1.525, 1.025, 0.125, &b));
  tree.updateNode(a, 2.0f);  // above the band where the floor is at z = 0
  tree.updateNode(b, 2.0f);  // in it
  slice.rebuild();
  EXPECT_EQ(slice.valueAt(1.025, 1.025), kUnknownCell);
  EXPECT_GT(slice.valueAt(1.525, 1.025), 50);
  // The floor under the first column is three layers up: its band is 0.20-0.35 there.
  const std::uint32_t column = std::uint32_t(a[0]) | std::uint32_t(a[1]) << 16;
  slice.shiftColumns({{column, 3}});
  EXPECT_EQ(slice.columnShift(a[0], a[1]), 3);
  EXPECT_GT(slice.valueAt(1.025, 1.025), 50);
  EXPECT_GT(slice.valueAt(1.525, 1.025), 50);  // the other column as it was
  // A change in the shifted band, outside the grid's own, reaches the column.
  tree.updateNode(a, -4.0f);
  const float after = tree.search(a)->getLogOdds();
  slice.updateColumns({a}, KeyBox::of({a}));
  EXPECT_LT(slice.valueAt(1.025, 1.025), 50);
  EXPECT_LT(after, 0.0f);
  // A rebuild keeps the shift; a shift of 0 takes it away.
  slice.rebuild();
  EXPECT_LT(slice.valueAt(1.025, 1.025), 50);
  slice.shiftColumns({{column, 0}});
  EXPECT_EQ(slice.valueAt(1.025, 1.025), kUnknownCell);
}

TEST(SliceGrid, ABandAcrossZeroReadsEachLayer) {
  // Keys of z < 0 and z >= 0 differ in their top bit: the band's columns share only the root.
  octomap::OcTree tree(0.05);
  SliceGrid slice(tree, SliceOptions{-0.20, 0.20});
  tree.updateNode(1.025, 1.025, -0.125, -2.0f);  // free below zero
  tree.updateNode(1.025, 1.025, 0.125, 2.0f);    // an obstacle above it
  slice.rebuild();
  EXPECT_GT(slice.valueAt(1.025, 1.025), 50);
}
