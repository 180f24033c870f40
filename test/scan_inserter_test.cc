#include "octo_slice_mapper/internal/scan_inserter.h"
#include "core/internal/scan_inserter_inspection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "octo_slice_mapper/mapper.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;
using octo_slice_mapper::test_support::laserPoseOnRobot;
using octo_slice_mapper::test_support::makeScan;

namespace {

const octomap::OcTreeNode* nodeAt(const octomap::OcTree& tree, double x, double y, double z) {
  return tree.search(x, y, z);
}

}  // namespace

TEST(ScanInserter, OneBeamIntoAnEmptyOctree) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  // Robot at the origin facing +x: the laser sits at (0.10, 0, 0.26); one beam straight ahead reads
  // 2.0 m, and the return at x = 2.10 lies on a voxel boundary: its peak goes to the voxels beside it.
  const InsertResult result = inserter.insert(makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, 0.01f, {2.0f}));
  inserter.flush();  // the octree is current only after a flush
  ASSERT_TRUE(result.ok()) << result.error;
  EXPECT_EQ(result.readings[ReadingKind::kHit], 1u);
  const double z = 0.26, hit_x = 2.10;
  // Free voxels along the ray at the laser height.
  for (double x = 0.15; x < hit_x - 0.15; x += 0.05) {
    const auto* n = nodeAt(tree, x, 0.0, z);
    ASSERT_NE(n, nullptr) << "x=" << x;
    EXPECT_LT(n->getLogOdds(), 0.0f) << "x=" << x;
  }
  // Occupied at the return: one of the two voxels beside it.
  const auto* before = nodeAt(tree, hit_x - 0.01, 0.0, z);
  const auto* hit = nodeAt(tree, hit_x, 0.0, z);
  ASSERT_NE(before, nullptr);
  ASSERT_NE(hit, nullptr);
  EXPECT_GT(std::max(before->getLogOdds(), hit->getLogOdds()), 0.0f);
  // Nothing beyond it, nothing above or below the ray.
  for (double x = hit_x + 0.15; x < 4.0; x += 0.05) EXPECT_EQ(nodeAt(tree, x, 0.0, z), nullptr) << "x=" << x;
  EXPECT_EQ(nodeAt(tree, 1.0, 0.0, z + 0.10), nullptr);
  EXPECT_EQ(nodeAt(tree, 1.0, 0.0, z - 0.10), nullptr);
  EXPECT_EQ(nodeAt(tree, 1.0, 0.2, z), nullptr) << "outside the beam's cone";
  // The touched box covers the ray.
  EXPECT_LE(tree.keyToCoord(result.touched.min[0]), 0.15);
  EXPECT_GE(tree.keyToCoord(result.touched.max[0]), hit_x);
}

// The box a scan reports bounds the voxels it changed, the ones the slice and the published
// update must follow; voxels updated without a change (at their clamping bound) are left out.
TEST(ScanInserter, TouchedBoundsTheChangedVoxels) {
  for (const double pitch : {0.0, 1.0 * M_PI / 180.0}) {  // the level path and the layered one
    octomap::OcTree tree(0.05);
    useMapperThresholds(MapperOptions{}, &tree);
    ScanInserter inserter(&tree, InsertOptions{});
    std::vector<float> ranges(61, 3.0f);
    ranges[30] = 1.5f;  // something nearer in the middle
    const Scan scan = makeScan(laserPoseOnRobot(0, 0, 0, pitch), -0.5f, 1.0f / 60.0f, ranges);
    InsertResult result = inserter.insert(scan);
    ASSERT_TRUE(result.ok());
    ASSERT_FALSE(result.updated_keys.empty());
    KeyBox changed;
    for (const octomap::OcTreeKey& k : result.updated_keys) changed.add(k);
    EXPECT_EQ(result.touched.min, changed.min) << "pitch " << pitch;
    EXPECT_EQ(result.touched.max, changed.max) << "pitch " << pitch;
    // The same scan again and again: most of its voxels reach their bounds and stop changing (a
    // few with nearly balanced evidence keep creeping); the box shrinks to those still changing.
    for (int i = 0; i < 40; ++i) result = inserter.insert(scan);
    KeyBox updated;  // every voxel the scan gives evidence to
    ScanInserterInspection(inserter).traceEvidence(scan, [&updated](const octomap::OcTreeKey& k, float value) {
      if (value != 0.0f) updated.add(k);
    });
    KeyBox still_changing;
    for (const octomap::OcTreeKey& k : result.updated_keys) still_changing.add(k);
    EXPECT_LT(result.updated_keys.size() * 4, result.voxels_updated) << "pitch " << pitch;
    EXPECT_EQ(result.touched.min, still_changing.min) << "pitch " << pitch;
    EXPECT_EQ(result.touched.max, still_changing.max) << "pitch " << pitch;
    const auto area = [](const KeyBox& b) {
      return b.empty() ? 0 : (b.max[0] - b.min[0] + 1) * (b.max[1] - b.min[1] + 1);
    };
    EXPECT_LT(area(result.touched), area(updated)) << "pitch " << pitch << ": the box of every update, not of the changes";
  }
}

TEST(ScanInserter, TiltedRobotTiltsTheRays) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  const double pitch = 10.0 * M_PI / 180.0;  // nose down (positive pitch about y points +x downwards)
  const Eigen::Isometry3d pose = laserPoseOnRobot(0, 0, 0, pitch);
  ASSERT_TRUE(inserter.insert(makeScan(pose, 0.0f, 0.01f, {2.0f})).ok());
  inserter.flush();
  const Eigen::Vector3d hit = pose * Eigen::Vector3d(2.0, 0.0, 0.0);
  EXPECT_LT(hit.z(), 0.0);
  const auto* n = nodeAt(tree, hit.x(), hit.y(), hit.z());
  ASSERT_NE(n, nullptr);
  EXPECT_GT(n->getLogOdds(), 0.0f);
  EXPECT_EQ(nodeAt(tree, hit.x(), hit.y(), 0.26), nullptr) << "a level ray would have ended here";
}

// 20 beams in practically the same direction all cross the same voxels: each voxel gets one
// update, the sum of the beams' evidence (or, occupied-wins, the strongest one).
TEST(ScanInserter, EachVoxelGetsOneCombinedUpdatePerScan) {
  for (EvidenceCombining combining : {EvidenceCombining::kSum, EvidenceCombining::kOccupiedWins}) {
    octomap::OcTree tree(0.05);
    tree.setClampingThresMin(1e-6);  // log-odds -13.8: no clamping of 20 beams' -8.1
    InsertOptions options;
    options.combining = combining;
    ScanInserter inserter(&tree, options);
    const Scan scan = makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, 1e-6f, std::vector<float>(20, 2.0f));
    const InsertResult result = inserter.insert(scan);
    ASSERT_TRUE(result.ok());
    inserter.flush();
    const auto* free_voxel = nodeAt(tree, 1.0, 0.0, 0.26);
    ASSERT_NE(free_voxel, nullptr);
    const double expected = (combining == EvidenceCombining::kSum ? 20.0 : 1.0) * inserter.model().logOddsFree();
    EXPECT_NEAR(free_voxel->getLogOdds(), expected, 1e-4);
    EXPECT_EQ(result.voxels_updated, result.updated_keys.size()) << "one update per voxel";
  }
}

TEST(ScanInserter, NeighbouringBeamDoesNotEraseAReturn) {
  octomap::OcTree tree(0.05);
  InsertOptions options;
  ScanInserter inserter(&tree, options);
  // Two adjacent beams: the first returns at 1.0 m, the second passes just beside it to 3.0 m.
  const float inc = 0.001f;
  const Scan scan = makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, inc, {1.02f, 3.0f});
  ASSERT_TRUE(inserter.insert(scan).ok());
  inserter.flush();
  const Eigen::Vector3d first_hit = scan.sensor_pose * Eigen::Vector3d(1.02, 0.0, 0.0);
  const Eigen::Vector3d second_near = scan.sensor_pose * (1.02 * Eigen::Vector3d(std::cos(inc), std::sin(inc), 0.0));
  octomap::OcTreeKey k1, k2;
  ASSERT_TRUE(tree.coordToKeyChecked(octomap::point3d(first_hit.x(), first_hit.y(), first_hit.z()), k1));
  ASSERT_TRUE(tree.coordToKeyChecked(octomap::point3d(second_near.x(), second_near.y(), second_near.z()), k2));
  ASSERT_EQ(k1, k2) << "test set-up: the second beam must cross the first beam's return voxel";
  const auto* n = tree.search(k1);
  ASSERT_NE(n, nullptr);
  EXPECT_GT(n->getLogOdds(), 0.0f);
}

TEST(ScanInserter, ClampingBoundsTheLogOdds) {
  octomap::OcTree tree(0.05);
  tree.setClampingThresMin(0.12);
  tree.setClampingThresMax(0.97);
  ScanInserter inserter(&tree, InsertOptions{});
  // Returns mid-voxel (x = 2.125 straight ahead), so that one voxel holds the peak.
  const Scan scan = makeScan(laserPoseOnRobot(0, 0, 0), -0.1f, 0.005f, std::vector<float>(41, 2.025f));
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(inserter.insert(scan).ok());
  inserter.flush();
  const auto* occupied = nodeAt(tree, 2.12, 0.0, 0.26);
  const auto* free_voxel = nodeAt(tree, 1.0, 0.0, 0.26);
  ASSERT_NE(occupied, nullptr);
  ASSERT_NE(free_voxel, nullptr);
  EXPECT_FLOAT_EQ(occupied->getLogOdds(), tree.getClampingThresMaxLog());
  EXPECT_FLOAT_EQ(free_voxel->getLogOdds(), tree.getClampingThresMinLog());
  // Clamping is what lets a person who walked away fade: a few free observations turn it free again.
  const Scan person_gone = makeScan(laserPoseOnRobot(0, 0, 0), -0.1f, 0.005f, std::vector<float>(41, 4.0f));
  for (int i = 0; i < 12; ++i) ASSERT_TRUE(inserter.insert(person_gone).ok());
  inserter.flush();
  EXPECT_LT(nodeAt(tree, 2.10, 0.0, 0.26)->getLogOdds(), 0.0f);
}

TEST(ScanInserter, InvalidReadingsAreCountedAndSkipped) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  // Beams 90 deg apart, one per kind (-inf: "too close" under REP 117).
  const Scan scan = makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, float(M_PI / 2), {nan, -inf, -1.0f, 0.01f}, 0.02f, 5.6f);
  const InsertResult result = inserter.insert(scan);
  inserter.flush();
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.readings[ReadingKind::kNaN], 1u);
  EXPECT_EQ(result.readings[ReadingKind::kInfinite], 1u);
  EXPECT_EQ(result.readings[ReadingKind::kNegative], 1u);
  EXPECT_EQ(result.readings[ReadingKind::kBelowMin], 1u);
  EXPECT_EQ(result.voxels_updated, 0u);
  EXPECT_EQ(tree.size(), 0u);
}

TEST(ScanInserter, NoReturnClearsWithoutMarkingOccupied) {
  octomap::OcTree tree(0.05);
  InsertOptions options;
  options.model.no_return_clear_distance = 3.0;
  ScanInserter inserter(&tree, options);
  const InsertResult result = inserter.insert(makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, 0.01f, {5.6f}));
  inserter.flush();
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.readings[ReadingKind::kNoReturn], 1u);
  std::size_t free_leaves = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    EXPECT_LE(it->getLogOdds(), 0.0f);
    EXPECT_LT(it.getX(), 0.10 + 3.0 + 0.3);
    ++free_leaves;
  }
  EXPECT_GT(free_leaves, 40u);
}

TEST(ScanInserter, RejectedScanLeavesTheMapUntouched) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  Scan scan = makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, 0.0f, {2.0f});
  const InsertResult result = inserter.insert(scan);
  inserter.flush();
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(tree.size(), 0u);
}

TEST(ScanInserter, MaxRangeCutsLongReturns) {
  octomap::OcTree tree(0.05);
  InsertOptions options;
  options.max_range = 1.0;
  ScanInserter inserter(&tree, options);
  ASSERT_TRUE(inserter.insert(makeScan(laserPoseOnRobot(0, 0, 0), 0.0f, 0.01f, {3.0f})).ok());
  inserter.flush();
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) EXPECT_LE(it->getLogOdds(), 0.0f);
  EXPECT_EQ(nodeAt(tree, 3.10, 0.0, 0.26), nullptr);
}

TEST(ScanInserter, PointCloudUsesTheSameModel) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  const Eigen::Vector3d origin(0.0, 0.0, 0.5);
  const InsertResult result = inserter.insertPoints(origin, {Eigen::Vector3f(2.025f, 0.0f, 0.525f)}, 0.005);
  inserter.flush();
  ASSERT_TRUE(result.ok());
  EXPECT_GT(nodeAt(tree, 2.02, 0.0, 0.52)->getLogOdds(), 0.0f);
  EXPECT_NEAR(nodeAt(tree, 1.0, 0.0, 0.5)->getLogOdds(), inserter.model().logOddsFree(), 1e-4);
}

// Regression (found by fuzz_laser_scan): coordinates far outside the octree reached OctoMap's
// coordToKeyChecked, whose int cast is undefined there (caught by scripts/test-sanitizers).
TEST(ScanInserter, CoordinatesOutsideTheTreeAreDroppedSafely) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  Eigen::Isometry3d far_away = Eigen::Isometry3d::Identity();
  far_away.translation() = Eigen::Vector3d(-1e308, 0.0, 0.26);  // finite, so the header check passes
  EXPECT_FALSE(inserter.insert(makeScan(far_away, -1.0f, 0.01f, std::vector<float>(201, 2.0f))).ok())
      << "refused with a reason";
  inserter.flush();
  EXPECT_EQ(tree.size(), 0u) << "a sensor outside the tree adds nothing";
  // A reading of 3e38 m under range_max = FLT_MAX: that beam leaves the tree and is dropped; its
  // neighbours still map.
  std::vector<float> ranges(201, 2.0f);
  ranges[100] = 3e38f;
  const InsertResult result =
      inserter.insert(makeScan(laserPoseOnRobot(0, 0, 0), -1.0f, 0.01f, ranges, 0.02f, std::numeric_limits<float>::max()));
  inserter.flush();
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.beams_outside_octree, 1u) << "dropped, and counted";
  EXPECT_EQ(result.readings[ReadingKind::kHit], 201u);
  // The returns at x = 2.10 lie on a voxel boundary: one of the voxels beside it is occupied.
  const octomap::OcTreeNode* before = tree.search(2.09, 0.0, 0.26);
  const octomap::OcTreeNode* after = tree.search(2.11, 0.0, 0.26);
  EXPECT_TRUE((before && tree.isNodeOccupied(before)) || (after && tree.isNodeOccupied(after)));
  EXPECT_EQ(tree.search(50.0, 0.0, 0.26), nullptr);
}

// Where the tracer skips the model (voxels surely in a beam's free valley, on the axis and on
// fanned rays inside the cone's full-weight part), it must hand on exactly what the model gives.
// Sparse scans (2-10 deg steps) and long ranges make wide cones, so most beams are fanned; some
// scans are tilted (the 3D walk), some readings are no-returns or cut by max_range.
TEST(ScanInserter, FreeValleyShortcutsGiveWhatTheModelGives) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (double resolution : {0.05, 0.1}) {
    octomap::OcTree tree(resolution);
    InsertOptions options;
    options.max_range = 18.0;
    ScanInserter inserter(&tree, options);
    std::size_t pairs = 0, free_pairs = 0;
    for (int n = 0; n < 24; ++n) {
      const float step = float((2.0 + 8.0 * unit(rng)) * M_PI / 180.0);
      std::vector<float> ranges(static_cast<std::size_t>(2.6 / step));
      for (float& r : ranges) {
        const double u = unit(rng);
        r = u < 0.1 ? 30.0f : float(0.2 + 20.0 * u * u);  // 30 m = no return
      }
      const double pitch = n % 4 == 3 ? 0.05 * unit(rng) : 0.0;
      Scan scan = makeScan(laserPoseOnRobot(unit(rng), unit(rng), 6.3 * unit(rng), pitch), -1.3f, step, ranges,
                           0.02f, 30.0f);
      std::vector<std::pair<octomap::OcTreeKey, float>> model, fast;
      ScanInserterInspection(inserter).traceEvidence(
          scan, [&](const octomap::OcTreeKey& k, float v) { model.emplace_back(k, v); });
      ScanInserterInspection(inserter).traceEvidence(
          scan, [&](const octomap::OcTreeKey& k, float v) { fast.emplace_back(k, v); }, /*shortcuts=*/true);
      ASSERT_EQ(fast.size(), model.size()) << "scan " << n;
      for (std::size_t i = 0; i < model.size(); ++i) {
        ASSERT_TRUE(fast[i].first == model[i].first) << "scan " << n << ", pair " << i;
        ASSERT_EQ(fast[i].second, model[i].second) << "scan " << n << ", pair " << i;
        free_pairs += model[i].second == inserter.model().logOddsFree();
      }
      pairs += model.size();
    }
    EXPECT_GT(pairs, 50000u);
    EXPECT_GT(free_pairs, pairs / 3) << "the free valley is most of a scan";
  }
}

// A beam that runs along a wall, 3 cm from the centres of the wall's voxels but never entering
// them, leaves the wall alone: only the voxels the axis crosses are judged on the axis (judged by
// their part nearest the axis, this beam would clear the wall it grazes).
TEST(ScanInserter, ABeamGrazingAWallClearsOnlyTheVoxelsItCrosses) {
  octomap::OcTree tree(0.05);
  useMapperThresholds(MapperOptions{}, &tree);
  for (double x = 0.025; x < 3.0; x += 0.05) tree.updateNode(octomap::point3d(x, 0.075, 0.275), 2.0f);
  ScanInserter inserter(&tree, InsertOptions{});
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(0.0, 0.045, 0.26);  // in the voxel row below the wall's
  ASSERT_TRUE(inserter.insert(makeScan(pose, 0.0f, 0.01f, {3.0f})).ok());
  inserter.flush();
  int cleared = 0, wall = 0;
  for (double x = 0.025; x < 2.9; x += 0.05, ++wall) {
    const auto* n = nodeAt(tree, x, 0.075, 0.275);
    ASSERT_NE(n, nullptr);
    cleared += n->getLogOdds() < 2.0f;
  }
  EXPECT_EQ(cleared, 0) << "of " << wall << " wall voxels";
  const auto* crossed = nodeAt(tree, 1.5, 0.045, 0.275);
  ASSERT_NE(crossed, nullptr);
  EXPECT_NEAR(crossed->getLogOdds(), inserter.model().logOddsFree(), 1e-4) << "the voxels it crosses are free";
}

// A sensor the octree cannot hold (a CARMEN pose of 1e30) is refused with a reason,
// not counted as inserted with nothing inserted.
TEST(ScanInserter, AnOriginOutsideTheOctreeIsRefused) {
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions{});
  for (double x : {1e30, 2000.0, -1700.0}) {
    const InsertResult r = inserter.insert(makeScan(laserPoseOnRobot(x, 0, 0), 0.0f, 0.01f, {1.0f, 2.0f}));
    EXPECT_FALSE(r.ok()) << x;
    EXPECT_NE(r.error.find("outside"), std::string::npos) << r.error;
  }
  EXPECT_FALSE(inserter.insertPoints(Eigen::Vector3d(0, 5000, 0), {Eigen::Vector3f(1, 1, 1)}, 0.01).ok());
  inserter.flush();
  EXPECT_EQ(tree.size(), 0u);
  EXPECT_TRUE(inserter.insert(makeScan(laserPoseOnRobot(1600, 0, 0), 0.0f, 0.01f, {1.0f})).ok()) << "inside: +-1638 m";
}
