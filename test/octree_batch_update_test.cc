#include "octo_slice_mapper/internal/octree_batch_update.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <algorithm>
#include <random>

#include "octo_slice_mapper/internal/scan_inserter.h"
#include "core/internal/scan_inserter_inspection.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;
using test_support::expectSameTree;

namespace {
// The depth of the leaf holding `key` (below the tree's depth: a pruned node).
unsigned depthOfLeaf(const octomap::OcTree& tree, const octomap::OcTreeKey& key) {
  const octomap::OcTreeNode* node = tree.getRoot();
  unsigned depth = 0;
  while (node && tree.nodeHasChildren(node)) {
    const unsigned pos = octomap::computeChildIdx(key, static_cast<int>(tree.getTreeDepth() - 1 - depth));
    if (!tree.nodeChildExists(node, pos)) return depth + 1;  // not held
    node = tree.getNodeChild(node, pos);
    ++depth;
  }
  return depth;
}

// Clamping bounds close enough that random updates saturate voxels and get nodes pruned.
void useTightClamping(octomap::OcTree* fast, octomap::OcTree* reference) {
  for (octomap::OcTree* t : {fast, reference}) {
    t->setClampingThresMin(0.12);
    t->setClampingThresMax(0.97);
  }
}

// Updates of unique keys drawn in a small volume (x, y within `reach` voxels of the origin, z
// within `z_layers` - 1), each a random value plus `bias`, so that nodes fill up, saturate, get
// pruned and expanded again over rounds.
std::vector<KeyUpdate> randomUniqueUpdates(std::mt19937* rng, const octomap::OcTree& tree, int reach, int z_layers,
                                           int draws, float bias) {
  std::uniform_int_distribution<int> coord(-reach, reach);
  std::uniform_real_distribution<float> value(-1.0f, 1.5f);
  std::vector<KeyUpdate> updates;
  octomap::KeySet seen;
  for (int n = 0; n < draws; ++n) {
    const octomap::OcTreeKey key = tree.coordToKey(coord(*rng) * 0.05, coord(*rng) * 0.05, (coord(*rng) % z_layers) * 0.05);
    if (seen.insert(key).second) updates.push_back({key, value(*rng) + bias});
  }
  return updates;
}
}  // namespace

TEST(OctreeBatchUpdate, RandomUpdatesMatchUpdateNodeOneByOne) {
  std::mt19937 rng(3);
  octomap::OcTree fast(0.05), reference(0.05);
  useTightClamping(&fast, &reference);
  for (int round = 0; round < 60; ++round) {
    std::vector<KeyUpdate> updates = randomUniqueUpdates(&rng, fast, 20, 4, 3000, round % 10 < 5 ? 0.8f : -0.8f);
    applyUpdatesOneByOne(&reference, updates);
    applyUpdatesInTreeOrder(&fast, &updates);
    ASSERT_NO_FATAL_FAILURE(expectSameTree(fast, reference)) << "round " << round;
  }
  EXPECT_GT(reference.getNumLeafNodes(), 1000u);
}

// The tree order is the Morton order of the keys (OctoMap's child index from the root down):
// checked against a comparison sort on keys on one side of the tree's centre key, straddling it in
// one axis (a depth frame's floor at z = 0) or in all three, and spread over the whole key range.
TEST(OctreeBatchUpdate, SortInTreeOrderIsTheMortonOrderOnBothSidesOfTheCentreKey) {
  const auto morton = [](const octomap::OcTreeKey& k) {
    std::uint64_t code = 0;
    for (int bit = 15; bit >= 0; --bit) {
      code = (code << 3) | octomap::computeChildIdx(k, bit);
    }
    return code;
  };
  std::mt19937 rng(9);
  struct Spread {
    int lo_xy, hi_xy, lo_z, hi_z;
  };
  for (const Spread& spread : {Spread{10, 90, 3, 40}, Spread{10, 90, -2, 40}, Spread{-50, 50, -20, 20},
                               Spread{-32000, 32000, -32000, 32000}, Spread{0, 0, 0, 0}}) {
    for (const std::size_t n : {std::size_t{1}, std::size_t{2}, std::size_t{7}, std::size_t{5000}}) {
      std::uniform_int_distribution<int> xy(spread.lo_xy, spread.hi_xy), z(spread.lo_z, spread.hi_z);
      std::vector<KeyUpdate> updates;
      for (std::size_t i = 0; i < n; ++i) {
        const octomap::OcTreeKey key(static_cast<std::uint16_t>(32768 + xy(rng)), static_cast<std::uint16_t>(32768 + xy(rng)),
                                     static_cast<std::uint16_t>(32768 + z(rng)));
        updates.push_back({key, static_cast<float>(i)});  // the value tells each update apart
      }
      std::vector<KeyUpdate> expected = updates;
      std::stable_sort(expected.begin(), expected.end(),
                       [&](const KeyUpdate& a, const KeyUpdate& b) { return morton(a.key) < morton(b.key); });
      sortInTreeOrder(&updates);
      ASSERT_EQ(updates.size(), expected.size());
      for (std::size_t i = 0; i < n; ++i) {
        ASSERT_EQ(updates[i].key, expected[i].key) << "spread " << spread.lo_xy << ".." << spread.hi_xy << ", n " << n;
        ASSERT_EQ(updates[i].log_odds, expected[i].log_odds) << "the sort is stable";
      }
    }
  }
}

// What applying `updates` (in tree order) reports per update against what updateNode one by one
// does to `reference`: the value before (NaN for a voxel the tree did not hold; a pruned voxel's
// is its parent's) and after. Counts the voxels new before, held by a pruned node before, and
// left unchanged.
struct ChangeCounts {
  std::size_t unknown_before = 0, pruned_before = 0, unchanged = 0;
};
void expectChangesOfUpdateNode(octomap::OcTree* fast, octomap::OcTree* reference, const std::vector<KeyUpdate>& updates,
                               ChangeCounts* counts) {
  std::vector<VoxelChange> expected;
  for (const KeyUpdate& u : updates) {
    const octomap::OcTreeNode* node = reference->search(u.key);
    const float before = node ? node->getLogOdds() : std::numeric_limits<float>::quiet_NaN();
    counts->pruned_before += node && depthOfLeaf(*reference, u.key) < reference->getTreeDepth();
    reference->updateNode(u.key, u.log_odds);
    expected.push_back({before, reference->search(u.key)->getLogOdds()});
  }
  std::vector<VoxelChange> changes;
  applySortedUpdates(fast, updates, &changes);
  ASSERT_EQ(changes.size(), updates.size());
  for (std::size_t i = 0; i < updates.size(); ++i) {
    if (std::isnan(expected[i].before)) {
      ASSERT_TRUE(std::isnan(changes[i].before)) << "update " << i;
      ++counts->unknown_before;
    } else {
      ASSERT_EQ(changes[i].before, expected[i].before) << "update " << i;
    }
    ASSERT_EQ(changes[i].after, expected[i].after) << "update " << i;
    counts->unchanged += changes[i].before == changes[i].after;
  }
  ASSERT_NO_FATAL_FAILURE(expectSameTree(*fast, *reference));
}

// Rounds of updates, draw(round, tree) each, sorted and applied to a tree with tight clamping,
// each round checked against updateNode one by one (expectChangesOfUpdateNode).
template <typename Draw>
void expectRoundsOfUpdateNode(int rounds, Draw&& draw, ChangeCounts* counts) {
  octomap::OcTree fast(0.05), reference(0.05);
  useTightClamping(&fast, &reference);
  for (int round = 0; round < rounds; ++round) {
    std::vector<KeyUpdate> updates = draw(round, fast);
    sortInTreeOrder(&updates);
    ASSERT_NO_FATAL_FAILURE(expectChangesOfUpdateNode(&fast, &reference, updates, counts)) << "round " << round;
  }
}

TEST(OctreeBatchUpdate, SortedUpdatesReportWhatEachDidToItsVoxel) {
  std::mt19937 rng(5);
  ChangeCounts counts;
  ASSERT_NO_FATAL_FAILURE(expectRoundsOfUpdateNode(
      40,
      [&](int round, const octomap::OcTree& tree) {
        return randomUniqueUpdates(&rng, tree, 12, 3, 2000, round % 8 < 4 ? 0.8f : -0.8f);
      },
      &counts));
  EXPECT_GT(counts.unknown_before, 1000u);
  EXPECT_GT(counts.pruned_before, 5u) << "voxels of pruned nodes (expanded by the update)";
  EXPECT_GT(counts.unchanged, 1000u) << "voxels at their bound stay there";
}

// Free space seen again: whole aligned blocks of voxels (2, 4 and 8 a side) with one value, as a
// depth frame's rays give them, which the batch applies to the block's node without its voxels
// (new, pruned, or pruned at a clamping bound), mixed with blocks it must not treat so: one voxel
// missing, one value different, an update leading away from the bound.
TEST(OctreeBatchUpdate, WholeBlocksAndNodesAtTheirBoundMatchUpdateNodeOneByOne) {
  std::mt19937 rng(11);
  ChangeCounts counts;
  std::uniform_int_distribution<int> cell(-1, 1), bits(1, 3), flaw(0, 5);
  const auto blocks = [&](int round, const octomap::OcTree&) {
    const float value = round % 10 < 7 ? -0.4f : 0.85f;  // free mostly, until clamped; then occupied
    std::vector<KeyUpdate> updates;
    octomap::KeySet seen;
    for (int n = 0; n < 30; ++n) {
      const int side = 1 << bits(rng);
      std::uniform_int_distribution<int> offset(0, 8 / side - 1);
      const int x0 = 8 * cell(rng) + side * offset(rng), y0 = 8 * cell(rng) + side * offset(rng),
                z0 = 8 * (cell(rng) % 2) + side * offset(rng);
      const int kind = flaw(rng);  // 0: one voxel missing, 1: one value different, 2: one leading away
      for (int i = 0; i < side * side * side; ++i) {
        const octomap::OcTreeKey key(static_cast<std::uint16_t>(32768 + x0 + i % side),
                                     static_cast<std::uint16_t>(32768 + y0 + i / side % side),
                                     static_cast<std::uint16_t>(32768 + z0 + i / (side * side)));
        if ((kind == 0 && i == 3) || !seen.insert(key).second) continue;
        updates.push_back({key, kind == 1 && i == 5 ? value * 0.5f : kind == 2 && i == 6 ? -value : value});
      }
    }
    return updates;
  };
  ASSERT_NO_FATAL_FAILURE(expectRoundsOfUpdateNode(40, blocks, &counts));
  EXPECT_GT(counts.unknown_before, 1000u);
  EXPECT_GT(counts.pruned_before, 5000u) << "voxels of pruned nodes";
  EXPECT_GT(counts.unchanged, 5000u) << "voxels at their bound stay there";
}

TEST(OctreeBatchUpdate, SimulatedScansMatchTheReference) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  octomap::OcTree fast(0.05), reference(0.05);
  ScanInserter inserter(&fast, InsertOptions{});
  ScanInserter reference_inserter(&reference, InsertOptions{});
  std::mt19937 rng(1);
  const auto times = session.scanTimes();
  for (std::size_t i = 0; i < times.size(); i += 4) {
    const Scan scan = session.scanAt(times[i], &rng);
    ASSERT_TRUE(inserter.insert(scan).ok());
    const double half_angle = reference_inserter.model().halfAngleFor(scan.angle_increment);
    applyUpdatesOneByOne(&reference, ScanInserterInspection(reference_inserter).computeUpdates(scan.sensor_pose.translation(),
                                                                       ScanInserterInspection(reference_inserter).beamsOf(scan, nullptr), half_angle));
  }
  inserter.flush();
  expectSameTree(fast, reference);
}

// A scan tilted by a degree (real odometry's pitch and roll) reaches a few layers: its
// updates go through the layer cache, and the octree is leaf for leaf the reference's. A scan
// tilted so far that it spans more than kMaxCachedLayersPerScan layers goes into the octree
// directly, and is right too.
TEST(OctreeBatchUpdate, TiltedScansMatchTheReferenceOnBothSidesOfTheLayerBound) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  const std::vector<Scan> level = session.allScans();
  for (const double degrees : {1.0, 25.0}) {
    octomap::OcTree fast(0.05), reference(0.05);
    ScanInserter inserter(&fast, InsertOptions{});
    ScanInserter reference_inserter(&reference, InsertOptions{});
    std::size_t most_layers = 0;
    for (std::size_t i = 0; i < level.size(); i += 8) {
      Scan scan = level[i];
      const double sign = (i / 8) % 2 ? 1.0 : -1.0;  // pitch and roll both ways
      scan.sensor_pose.rotate(Eigen::AngleAxisd(sign * degrees * M_PI / 180.0, Eigen::Vector3d::UnitY()));
      scan.sensor_pose.rotate(Eigen::AngleAxisd(0.5 * degrees * M_PI / 180.0, Eigen::Vector3d::UnitX()));
      const InsertResult result = inserter.insert(scan);
      ASSERT_TRUE(result.ok());
      most_layers = std::max<std::size_t>(most_layers, result.touched.max[2] - result.touched.min[2] + 1);
      const double half_angle = reference_inserter.model().halfAngleFor(scan.angle_increment);
      applyUpdatesOneByOne(&reference, ScanInserterInspection(reference_inserter).computeUpdates(scan.sensor_pose.translation(),
                                                                         ScanInserterInspection(reference_inserter).beamsOf(scan, nullptr),
                                                                         half_angle));
    }
    const octomap::OcTreeKey origin = fast.coordToKey(level[0].sensor_pose.translation().x(),
                                                      level[0].sensor_pose.translation().y(),
                                                      level[0].sensor_pose.translation().z());
    if (degrees < 2.0) {
      EXPECT_GT(most_layers, 1u) << "a 1 degree tilt over 5.6 m crosses layers";
      EXPECT_LE(most_layers, ScanInserter::kMaxCachedLayersPerScan);
      EXPECT_NE(inserter.cache().findLayer(origin[2] + 1), nullptr) << "the layers beside the laser's are cached";
    } else {
      EXPECT_GT(most_layers, ScanInserter::kMaxCachedLayersPerScan);
      EXPECT_TRUE(inserter.cache().empty()) << "scans over more layers go into the octree";
    }
    inserter.flush();
    SCOPED_TRACE(std::to_string(degrees) + " degrees");
    expectSameTree(fast, reference);
  }
}
