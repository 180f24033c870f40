// The insertion fast path (level scans into the layer cache, flushed later) against the
// straightforward reference: per scan, each voxel's evidence combined in a std::map, then one
// OcTree::updateNode per voxel. Same keys, same log-odds, same nodes.
#include "octo_slice_mapper/internal/layer_cache.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <thread>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/internal/scan_inserter.h"
#include "core/internal/scan_inserter_inspection.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;
using test_support::laserPoseOnRobot;
using test_support::expectSameTree;
using test_support::makeScan;

namespace {

// The reference: updateNode once per voxel per scan with the combined evidence (the sum of the
// beams' evidence, in the order they give it; or the strongest occupied evidence, else the
// strongest free evidence).
void insertByUpdateNode(ScanInserter* tracer, octomap::OcTree* tree, const Scan& scan) {
  struct Evidence {
    float sum = 0.0f, most_occupied = 0.0f, most_free = 0.0f;
  };
  std::map<octomap::OcTreeKey, Evidence, bool (*)(const octomap::OcTreeKey&, const octomap::OcTreeKey&)> evidence(
      [](const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
        return std::make_tuple(a[0], a[1], a[2]) < std::make_tuple(b[0], b[1], b[2]);
      });
  ScanInserterInspection(*tracer).traceEvidence(scan, [&](const octomap::OcTreeKey& key, float value) {
    Evidence& e = evidence[key];
    e.sum += value;
    e.most_occupied = std::max(e.most_occupied, value);
    e.most_free = std::min(e.most_free, value);
  });
  for (const auto& [key, e] : evidence) {
    const float update = tracer->options().combining == EvidenceCombining::kSum ? e.sum
                         : e.most_occupied > 0.0f                               ? e.most_occupied
                                                                                : e.most_free;
    if (update != 0.0f) tree->updateNode(key, update);
  }
}

InsertOptions combiningBy(EvidenceCombining combining) {
  InsertOptions o;
  o.combining = combining;
  return o;
}

void clampLikeTheMapper(octomap::OcTree* tree) { useMapperThresholds(MapperOptions{}, tree); }

}  // namespace

// Level scans of a simulated tour, a few tilted ones (generic path, partly through the cache),
// flushes at random moments, and a map that already holds data (loaded values outside the
// clamping bounds, pruned nodes) before the first scan.
class LayerCacheBothRules : public ::testing::TestWithParam<EvidenceCombining> {};
INSTANTIATE_TEST_SUITE_P(Combining, LayerCacheBothRules,
                         ::testing::Values(EvidenceCombining::kSum, EvidenceCombining::kOccupiedWins));

TEST_P(LayerCacheBothRules, FastPathGivesTheSameOctreeAsUpdateNodePerVoxel) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  octomap::OcTree fast(0.05), reference(0.05), tracer_tree(0.05);
  for (octomap::OcTree* t : {&fast, &reference, &tracer_tree}) clampLikeTheMapper(t);
  // Prior content: a saturated block (pruned into larger nodes) and a few voxels beyond the
  // bounds, as a map saved with other clamping would have them.
  for (octomap::OcTree* t : {&fast, &reference}) {
    for (double x = 0.0; x < 0.8; x += 0.05) {
      for (double y = -0.4; y < 0.4; y += 0.05) {
        for (double z = 0.0; z < 0.4; z += 0.05) t->setNodeValue(x, y, z, t->getClampingThresMaxLog());
      }
    }
    t->updateNode(octomap::point3d(1.0f, 1.0f, 0.275f), 5.0f, true);
    t->updateNode(octomap::point3d(1.05f, 1.0f, 0.275f), -5.0f, true);
    t->updateInnerOccupancy();
  }
  ScanInserter inserter(&fast, combiningBy(GetParam()));
  ScanInserter tracer(&tracer_tree, combiningBy(GetParam()));  // only traces (its own tree stays empty)
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> coin(0, 9);
  const auto times = session.scanTimes();
  std::size_t level = 0, tilted = 0, flushes = 0, partial_flushes = 0;
  for (std::size_t i = 0; i < times.size(); i += 3) {
    Scan scan = session.scanAt(times[i], &rng);
    if (coin(rng) == 0) {  // tilt the laser a little: the generic 3D path
      scan.sensor_pose.rotate(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitY()));
      ++tilted;
    } else {
      ++level;
    }
    ASSERT_TRUE(inserter.insert(scan).ok());
    insertByUpdateNode(&tracer, &reference, scan);
    if (coin(rng) == 0) {
      inserter.flush();
      ++flushes;
    } else if (coin(rng) < 3) {  // the oldest part of the backlog only, as the Mapper bounds it
      inserter.cache().flushOldest(inserter.cache().dirtyCount() / (1 + coin(rng)));
      ++partial_flushes;
    }
  }
  inserter.flush();
  EXPECT_GT(level, 100u);
  EXPECT_GT(tilted, 10u);
  EXPECT_GT(flushes, 10u);
  EXPECT_GT(partial_flushes, 20u);
  EXPECT_GT(reference.getNumLeafNodes(), 10000u);
  expectSameTree(fast, reference);
}

// Returns so far apart that the scan's key box is too large for the evidence window: the
// updates are combined in a hash map instead, and must give the reference's octree too, on the
// level path and on the generic one.
TEST_P(LayerCacheBothRules, TooLargeABoxForTheWindowGivesTheSameOctree) {
  octomap::OcTree fast(0.05), reference(0.05), tracer_tree(0.05);
  for (octomap::OcTree* t : {&fast, &reference, &tracer_tree}) clampLikeTheMapper(t);
  // Two returns 210 m out, one along x and one along y (the beams between them read nothing),
  // inserted whole (max_range 0: the sensor's 250 m).
  InsertOptions options = combiningBy(GetParam());
  options.max_range = 0.0;
  ScanInserter inserter(&fast, options);
  ScanInserter tracer(&tracer_tree, options);
  constexpr float kRange = 210.0f, kIncrement = 0.01f;
  const int beams = int(std::lround(M_PI / 2 / kIncrement)) + 1;
  std::vector<float> ranges(beams, std::numeric_limits<float>::quiet_NaN());
  ranges.front() = ranges.back() = kRange;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation().z() = 0.26;
  Scan level = makeScan(pose, 0.0f, kIncrement, ranges, 0.02f, 250.0f);
  KeyBox box;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0.26), Eigen::Vector3d(kRange, 0, 0.26),
                                   Eigen::Vector3d(0, kRange, 0.26)}) {
    box.add(fast.coordToKey(p.x(), p.y(), p.z()));
  }
  ScanEvidence window;
  ASSERT_FALSE(window.begin(box, 1)) << "the scan must be too large for a window";
  Scan tilted = level;
  tilted.sensor_pose.rotate(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()));
  for (const Scan& scan : {level, tilted}) {
    ASSERT_TRUE(inserter.insert(scan).ok());
    insertByUpdateNode(&tracer, &reference, scan);
  }
  inserter.flush();
  EXPECT_GT(reference.getNumLeafNodes(), 8000u);
  expectSameTree(fast, reference);
}

TEST(LayerCache, RepeatsUpdateNodeArithmeticPerVoxel) {
  octomap::OcTree cached(0.1), reference(0.1);
  for (octomap::OcTree* t : {&cached, &reference}) clampLikeTheMapper(t);
  // A voxel loaded above the upper bound keeps its value under positive updates (updateNode's
  // early out) and drops below it under a negative one.
  const octomap::OcTreeKey high = cached.coordToKey(0.05, 0.05, 0.05), low = cached.coordToKey(0.15, 0.05, 0.05);
  for (octomap::OcTree* t : {&cached, &reference}) {
    t->setNodeValue(high, 0.0f);
    t->search(high)->setLogOdds(6.0f);  // beyond the bound, as setNodeValue would not allow
    t->setNodeValue(low, t->getClampingThresMinLog());
  }
  LayerCache cache(&cached);
  const std::vector<std::pair<octomap::OcTreeKey, float>> updates = {
      {high, 0.4f}, {low, -0.4f}, {high, -0.4f}, {low, 0.85f}, {cached.coordToKey(0.35, 0.05, 0.05), 0.85f}};
  for (const auto& [key, value] : updates) {
    cache.apply(key, value);
    reference.updateNode(key, value);
  }
  float value = 0.0f;
  ASSERT_EQ(cache.lookup(high[0], high[1], high[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, reference.search(high)->getLogOdds());
  EXPECT_EQ(cache.lookup(high[0], high[1] + 1, high[2], &value), LayerCache::Lookup::kUnknown)
      << "a new tile loads what the tree holds of its layer: nothing there";
  EXPECT_GT(cache.dirtyCount(), 0u);
  cache.flush();
  EXPECT_EQ(cache.dirtyCount(), 0u);
  expectSameTree(cached, reference);
  cache.flush();  // nothing left to write: no change
  expectSameTree(cached, reference);
}

// flushOldest writes whole tiles, those whose first waiting value has waited longest, until it
// has written as many values as asked; a tile changed again after being written waits again
// (behind the others).
TEST(LayerCache, FlushOldestWritesTheLongestWaitingTilesFirst) {
  octomap::OcTree cached(0.1), reference(0.1);
  for (octomap::OcTree* t : {&cached, &reference}) clampLikeTheMapper(t);
  LayerCache cache(&cached);
  // Tiles A, B and C side by side in one layer, 10, 20 and 30 voxels changed in that order.
  std::vector<std::vector<octomap::OcTreeKey>> tiles(3);
  for (unsigned t = 0; t < 3; ++t) {
    for (unsigned i = 0; i < 10 * (t + 1); ++i) {
      tiles[t].emplace_back(32768 + 64 * t + i, 32768 + (i * 7) % 13, 32770);
    }
  }
  const auto change = [&](const octomap::OcTreeKey& k, float update) {
    ASSERT_TRUE(cache.apply(k, update));
    reference.updateNode(k, update);
  };
  for (const auto& tile : tiles) {
    for (const octomap::OcTreeKey& k : tile) change(k, 0.85f);
  }
  change(octomap::OcTreeKey(32768 + 40, 32770, 32770), 0.85f);  // A again: it waits since its first
  EXPECT_EQ(cache.dirtyCount(), 61u);
  const auto written = [&](const octomap::OcTreeKey& k) { return cached.search(k) != nullptr; };
  cache.flushOldest(5);  // all of A
  EXPECT_EQ(cache.dirtyCount(), 50u);
  for (const octomap::OcTreeKey& k : tiles[0]) EXPECT_TRUE(written(k));
  EXPECT_TRUE(written(octomap::OcTreeKey(32768 + 40, 32770, 32770)));
  for (const octomap::OcTreeKey& k : tiles[1]) EXPECT_FALSE(written(k));
  change(tiles[0][0], -0.4f);  // written, changed again: waits behind B and C
  EXPECT_EQ(cache.dirtyCount(), 51u);
  cache.flushOldest(21);  // B (20) is not enough: C too
  EXPECT_EQ(cache.dirtyCount(), 1u);
  for (const octomap::OcTreeKey& k : tiles[2]) EXPECT_TRUE(written(k));
  EXPECT_EQ(cached.search(tiles[0][0])->getLogOdds(), 0.85f) << "its new value has not waited long enough";
  cache.flushOldest(1000);  // more than wait: all of them
  EXPECT_EQ(cache.dirtyCount(), 0u);
  EXPECT_EQ(cached.search(tiles[0][0])->getLogOdds(), 0.85f - 0.4f);
  cached.updateInnerOccupancy();
  reference.updateInnerOccupancy();
  expectSameTree(cached, reference);
}

// A tile's waiting voxels come out of its dirty bits in the order sortInTreeOrder gives them,
// for any set of them (none, one, some, all), on both sides of the octree's centre key.
TEST(LayerCache, TilesWaitingVoxelsComeInTreeOrder) {
  std::mt19937 rng(11);
  for (const std::uint16_t x0 : {std::uint16_t(32768 - 64), std::uint16_t(32768 + 128)}) {
    for (const double share : {0.0, 0.0003, 0.01, 0.1, 0.5, 1.0}) {
      LayerCache::Tile tile(LayerCache::unknownValue(), 32771, x0, 32768 - 192);
      std::bernoulli_distribution dirty(share);
      std::vector<KeyUpdate> expected;
      for (unsigned y = 0; y < LayerCache::kTileSize; ++y) {
        for (unsigned x = 0; x < LayerCache::kTileSize; ++x) {
          if (!dirty(rng)) continue;
          tile.value[LayerCache::cellIndex(x, y)] = float(x) - 0.5f * float(y);
          tile.dirty[y] |= std::uint64_t{1} << x;
          expected.push_back({octomap::OcTreeKey(x0 + x, tile.y0 + y, tile.z), float(x) - 0.5f * float(y)});
        }
      }
      sortInTreeOrder(&expected);
      std::vector<KeyUpdate> got;
      LayerCache::appendDirtyInTreeOrder(tile, &got);
      ASSERT_EQ(got.size(), expected.size()) << "share " << share;
      for (std::size_t i = 0; i < got.size(); ++i) {
        ASSERT_EQ(got[i].key, expected[i].key) << "share " << share << ", voxel " << i;
        ASSERT_EQ(got[i].log_odds, expected[i].log_odds);
      }
    }
  }
}

// A tile over ground the octree holds nothing of starts as known-unknown (one search); one next
// to existing nodes loads them all, once, when it is made: the voxels an update reaches and the
// ones the slice reads then need no search of their own.
TEST(LayerCache, NewTileKnowsWhatTheOctreeHolds) {
  octomap::OcTree tree(0.1);
  const octomap::OcTreeKey seen = tree.coordToKey(0.05, 0.05, 0.05);
  tree.setNodeValue(seen, 1.0f);
  LayerCache cache(&tree);
  const octomap::OcTreeKey next(seen[0] + 1, seen[1], seen[2]), far(seen[0] + 640, seen[1], seen[2]);
  ASSERT_TRUE(cache.apply(next, 0.5f));
  ASSERT_TRUE(cache.apply(far, 0.5f));
  float value = 0.0f;
  ASSERT_EQ(cache.lookup(seen[0], seen[1], seen[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, 1.0f) << "loaded with its tile";
  EXPECT_EQ(cache.lookup(seen[0], seen[1] + 1, seen[2], &value), LayerCache::Lookup::kUnknown);
  EXPECT_EQ(cache.lookup(far[0] + 1, far[1], far[2], &value), LayerCache::Lookup::kUnknown);
  ASSERT_TRUE(cache.apply(seen, 0.5f));
  ASSERT_EQ(cache.lookup(seen[0], seen[1], seen[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, 1.5f) << "the octree's value was the start of the update";
}

// A voxel's value slot also says whether it has one: unknown, forgotten (read the octree again)
// or a log-odds. Dirty marks are per voxel, even for neighbours in one row of a tile.
TEST(LayerCache, ForgottenVoxelIsReadAgainAndDirtyMarksArePerVoxel) {
  octomap::OcTree tree(0.1);
  clampLikeTheMapper(&tree);
  LayerCache cache(&tree);
  // b in the next tile (voxels are written a tile at a time); c in a's tile and row, 63 voxels on.
  const octomap::OcTreeKey a(32768, 32768, 32770), b(32768 + 64, 32768, 32770), c(32768 + 63, 32768, 32770);
  ASSERT_TRUE(cache.apply(a, 0.85f));
  ASSERT_TRUE(cache.apply(b, -0.4f));
  EXPECT_EQ(cache.dirtyCount(), 2u);
  ASSERT_TRUE(cache.apply(a, 0.85f));
  EXPECT_EQ(cache.dirtyCount(), 2u) << "a voxel already waiting is listed once";
  cache.flushOldest(1);  // a's tile: a only
  EXPECT_EQ(tree.search(a)->getLogOdds(), 1.7f);
  EXPECT_EQ(tree.search(b), nullptr);
  ASSERT_TRUE(cache.apply(c, 0.85f));
  EXPECT_EQ(cache.dirtyCount(), 2u) << "b and c wait; a was written";
  cache.flush();
  EXPECT_EQ(tree.search(b)->getLogOdds(), -0.4f);
  EXPECT_EQ(tree.search(c)->getLogOdds(), 0.85f);

  // The octree changed behind the cache's back; after forget() the cache reads it again.
  tree.setNodeValue(a, -1.0f);
  float value = 0.0f;
  ASSERT_EQ(cache.lookup(a[0], a[1], a[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, 1.7f) << "the cache still holds its own value";
  cache.forget(a);
  EXPECT_EQ(cache.lookup(a[0], a[1], a[2], &value), LayerCache::Lookup::kNotCached);
  ASSERT_TRUE(cache.apply(a, 0.85f));
  ASSERT_EQ(cache.lookup(a[0], a[1], a[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, -1.0f + 0.85f) << "the update started from the octree's value";
  // A forgotten voxel the octree holds nothing of is unknown again, not zero and not a value.
  const octomap::OcTreeKey d(32770, 32768, 32770);
  cache.forget(d);
  ASSERT_TRUE(cache.apply(d, -0.4f));
  ASSERT_EQ(cache.lookup(d[0], d[1], d[2], &value), LayerCache::Lookup::kKnown);
  EXPECT_EQ(value, -0.4f);
  EXPECT_EQ(cache.lookup(d[0] + 1, d[1], d[2], &value), LayerCache::Lookup::kUnknown);
  cache.flush();
  EXPECT_EQ(cache.dirtyCount(), 0u);
  EXPECT_FLOAT_EQ(tree.search(a)->getLogOdds(), -0.15f);
}

// A pruned leaf spans several layers and columns: a tile of one of its layers takes its value
// for each voxel it covers, and a tile of the layer just above it takes nothing from it (OctoMap's
// box iterator hands on such neighbours too).
TEST(LayerCache, NewTileLoadsPrunedLeavesOfItsLayerOnly) {
  octomap::OcTree tree(0.1);
  const octomap::OcTreeKey corner(32768, 32768, 32768);  // a 4 x 4 x 4 block (a pruned depth-14 leaf) in one tile
  for (unsigned dz = 0; dz < 4; ++dz) {
    for (unsigned dy = 0; dy < 4; ++dy) {
      for (unsigned dx = 0; dx < 4; ++dx) tree.setNodeValue(octomap::OcTreeKey(corner[0] + dx, corner[1] + dy, corner[2] + dz), 2.0f);
    }
  }
  tree.prune();
  unsigned depth = 0;
  ASSERT_TRUE(tree.search(corner, 0) != nullptr);
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) depth = it.getDepth();
  ASSERT_EQ(depth, tree.getTreeDepth() - 2) << "the block should be one pruned leaf";
  LayerCache cache(&tree);
  ASSERT_TRUE(cache.apply(octomap::OcTreeKey(corner[0] + 10, corner[1], corner[2] + 1), 0.5f));  // makes layer z+1's tile
  ASSERT_TRUE(cache.apply(octomap::OcTreeKey(corner[0] + 10, corner[1], corner[2] + 4), 0.5f));  // the layer above the block
  float value = 0.0f;
  for (unsigned dy = 0; dy < 5; ++dy) {
    for (unsigned dx = 0; dx < 5; ++dx) {
      const bool inside = dx < 4 && dy < 4;
      const auto in_block = cache.lookup(corner[0] + dx, corner[1] + dy, corner[2] + 1, &value);
      EXPECT_EQ(in_block, inside ? LayerCache::Lookup::kKnown : LayerCache::Lookup::kUnknown) << dx << "," << dy;
      if (inside) {
        EXPECT_EQ(value, 2.0f);
      }
      EXPECT_EQ(cache.lookup(corner[0] + dx, corner[1] + dy, corner[2] + 4, &value), LayerCache::Lookup::kUnknown)
          << dx << "," << dy;
    }
  }
}

// The Mapper reads through the cache: its slice equals one rebuilt from the flushed tree, and
// its tree() is current without the caller flushing.
TEST(LayerCache, MapperSliceAndTreeSeeCachedValues) {
  Mapper mapper;
  std::vector<float> ranges(181, 2.0f);
  ASSERT_TRUE(mapper.insert(makeScan(laserPoseOnRobot(0, 0, 0), -1.57f, 0.01745f, ranges)).ok());
  EXPECT_GT(mapper.inserter().cache().dirtyCount(), 0u);
  const std::vector<std::int8_t> incremental = mapper.slice().data();
  const octomap::OcTree& tree = mapper.tree();  // flushes
  EXPECT_EQ(mapper.inserter().cache().dirtyCount(), 0u);
  EXPECT_GT(tree.getNumLeafNodes(), 100u);
  SliceGrid rebuilt(tree, mapper.options().slice);
  rebuilt.rebuild();
  int known = 0;
  for (int j = 0; j < rebuilt.height(); ++j) {
    for (int i = 0; i < rebuilt.width(); ++i) {
      const double x = rebuilt.originX() + (i + 0.5) * rebuilt.resolution();
      const double y = rebuilt.originY() + (j + 0.5) * rebuilt.resolution();
      ASSERT_EQ(mapper.slice().valueAt(x, y), rebuilt.at(i, j)) << i << "," << j;
      known += rebuilt.at(i, j) != kUnknownCell;
    }
  }
  EXPECT_GT(known, 100);
  (void)incremental;
}

// The Mapper keeps the cache's backlog within max_unflushed_voxels after every scan and every
// cloud (a camera alone too), writing the longest-waiting voxels, and its octree ends as one
// mapped without any bound.
TEST(LayerCache, MapperBoundsTheBacklogAfterScansAndClouds) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  MapperOptions bounded_options, unbounded_options;
  bounded_options.max_unflushed_voxels = 3000;
  unbounded_options.max_unflushed_voxels = std::size_t{1} << 30;
  Mapper bounded(bounded_options), unbounded(unbounded_options);
  std::mt19937 rng(4);
  const auto times = session.scanTimes();
  std::size_t most = 0, flushed_some = 0;
  for (std::size_t i = 0; i < times.size(); i += 4) {
    Scan scan = session.scanAt(times[i], &rng);
    if (i % 40 == 0) scan.sensor_pose.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()));
    const std::size_t before = bounded.flushedTree().size();
    ASSERT_TRUE(bounded.insert(scan).ok());
    ASSERT_TRUE(unbounded.insert(scan).ok());
    most = std::max(most, bounded.unflushedVoxels());
    flushed_some += bounded.flushedTree().size() != before;
  }
  EXPECT_LE(most, 3000u);
  EXPECT_GT(flushed_some, 5u) << "the bound should have been reached";
  EXPECT_GT(unbounded.unflushedVoxels(), 3000u) << "the session should exceed the bound";
  // A camera's clouds alone: a wall of points 2 m ahead, moved a little each frame.
  const Eigen::Vector3d camera(0.1, 0.0, 0.3);
  for (int frame = 0; frame < 40; ++frame) {
    std::vector<Eigen::Vector3f> points;
    for (int u = 0; u < 60; ++u) {
      for (int v = 0; v < 40; ++v) {
        points.emplace_back(2.0f + 0.01f * float(frame % 7), -1.5f + 0.05f * float(u), 0.05f * float(v));
      }
    }
    ASSERT_TRUE(bounded.insertPoints(camera, points).ok());
    ASSERT_TRUE(unbounded.insertPoints(camera, points).ok());
    EXPECT_LE(bounded.unflushedVoxels(), 3000u) << "frame " << frame;
  }
  expectSameTree(bounded.tree(), unbounded.tree());
  EXPECT_EQ(unbounded.unflushedVoxels(), 0u) << "tree() writes everything";
}

// A snapshot lends the octree: another thread reads it (here: saves it) while scans keep coming;
// the lent tree does not change meanwhile, and afterwards the octree catches up with the scans.
TEST(LayerCache, MapperLendsItsOctreeWhileScansGoOn) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  Mapper mapper;
  std::mt19937 rng(2);
  const auto times = session.scanTimes();
  const std::size_t half = times.size() / 2;
  for (std::size_t i = 0; i < half; i += 2) ASSERT_TRUE(mapper.insert(session.scanAt(times[i], &rng)).ok());

  MapSnapshot snapshot = mapper.snapshot(/*with_scans=*/false);
  const std::size_t lent_leaves = snapshot.tree->getNumLeafNodes();
  octomap::OcTree lent_copy(*snapshot.tree);
  char tmpl[] = "/tmp/osm_lend_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  bool saved = false;
  std::string error;
  std::thread saver([&] { saved = saveFullTree(*snapshot.tree, dir + "/lent.ot", &error); });
  for (std::size_t i = half; i < times.size(); i += 2) {  // a tilted scan now and then: generic path
    Scan scan = session.scanAt(times[i], &rng);
    if (i % 20 == 0) scan.sensor_pose.rotate(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitY()));
    ASSERT_TRUE(mapper.insert(scan).ok());
  }
  saver.join();
  ASSERT_TRUE(saved) << error;
  EXPECT_EQ(snapshot.tree->getNumLeafNodes(), lent_leaves) << "the lent octree changed";
  EXPECT_EQ(&mapper.tree(), snapshot.tree) << "while lent, tree() gives the lent state";
  EXPECT_EQ(mapper.tree().getNumLeafNodes(), lent_leaves);
  EXPECT_THROW(mapper.reset(), std::logic_error);
  std::unique_ptr<octomap::OcTree> written = loadTree(dir + "/lent.ot", &error);
  ASSERT_TRUE(written) << error;
  expectSameTree(*written, lent_copy);

  mapper.endSnapshot();
  EXPECT_GT(mapper.tree().getNumLeafNodes(), lent_leaves) << "the second half reached the octree";
  // ... exactly as if it had never been lent.
  Mapper straight;
  std::mt19937 rng2(2);
  for (std::size_t i = 0; i < times.size(); i += 2) {
    Scan scan = session.scanAt(times[i], &rng2);
    if (i >= half && i % 20 == 0) scan.sensor_pose.rotate(Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitY()));
    ASSERT_TRUE(straight.insert(scan).ok());
  }
  expectSameTree(mapper.tree(), straight.tree());
}

// The global pass's input comes without the octree: the insertion cache stays as it is (no flush
// under the node's lock) and nothing is lent, yet the slice and the scans are those of the map.
TEST(LayerCache, OptimizationInputLeavesTheCacheAlone) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  Mapper mapper;
  std::mt19937 rng(3);
  const auto times = session.scanTimes();
  for (std::size_t i = 0; i < times.size() / 4; i += 2) ASSERT_TRUE(mapper.insert(session.scanAt(times[i], &rng)).ok());
  const std::size_t waiting = mapper.inserter().cache().dirtyCount();
  ASSERT_GT(waiting, 0u);

  const MapSnapshot input = mapper.optimizationInput();
  EXPECT_EQ(input.tree, nullptr);
  EXPECT_FALSE(mapper.lent());
  EXPECT_EQ(mapper.inserter().cache().dirtyCount(), waiting) << "the cache was flushed";
  EXPECT_EQ(input.scans.size(), mapper.scanStore().scans().size());
  EXPECT_GT(input.scans.size(), 10u);
  EXPECT_EQ(input.band_lo, mapper.slice().bandMinKey());
  EXPECT_EQ(input.band_hi, mapper.slice().bandMaxKey());
  const MapSnapshot lent = mapper.snapshot(/*with_scans=*/true);  // the lending way, for comparison
  EXPECT_EQ(mapper.inserter().cache().dirtyCount(), 0u);
  EXPECT_EQ(input.slice.cells, lent.slice.cells);
  EXPECT_EQ(input.slice.width, lent.slice.width);
  EXPECT_EQ(input.slice.origin_x, lent.slice.origin_x);
  mapper.endSnapshot();
}
