#include "octo_slice_mapper/slice_grid.h"

#include <gtest/gtest.h>

#include <cmath>

#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

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
