#include "octo_slice_mapper/optimized_map.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "octo_slice_mapper/held_out_score.h"
#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/sim/session.h"

using namespace octo_slice_mapper;

namespace {

// The office session through the Mapper: it keeps its scans, the global pass runs over them.
class OptimizedMapTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
    mapper_ = new Mapper();
    for (const Scan& s : session.allScans()) ASSERT_TRUE(mapper_->insert(s).ok());
    truth_ = new GridImage(session.plan().groundTruth(0.05));
  }
  static void TearDownTestSuite() {
    delete mapper_;
    delete truth_;
  }
  static Mapper* mapper_;
  static GridImage* truth_;
};
Mapper* OptimizedMapTest::mapper_ = nullptr;
GridImage* OptimizedMapTest::truth_ = nullptr;

TEST_F(OptimizedMapTest, MapperKeepsItsScansForTheGlobalPass) {
  // All but the ones taken where a kept scan was taken (the robot standing still).
  EXPECT_EQ(mapper_->scanStore().scans().size() + mapper_->scanStore().skippedAsRevisit(),
            mapper_->stats().scans_inserted);
  EXPECT_GT(mapper_->scanStore().scans().size(), mapper_->stats().scans_inserted / 2);
  EXPECT_GT(mapper_->scanStore().memoryBytes(), 1000000u);
}

TEST_F(OptimizedMapTest, OptimizedGridGoesIntoTheBandAndIntoTheBtFile) {
  const OptimizedMap optimized = mapper_->optimize(/*warm_start=*/false);
  ASSERT_TRUE(optimized.report.converged);
  const OccupancyScore score = scoreOccupancy(optimized.grid, *truth_, 1);
  std::printf("[ optimized office ] precision %.4f recall %.4f, %d sweeps\n", score.precision, score.recall,
              optimized.report.sweeps);
  EXPECT_GE(score.precision, 0.9);

  char tmpl[] = "/tmp/osm_optimized_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  std::vector<std::string> written;
  std::string error;
  const std::size_t leaves_before = mapper_->tree().getNumLeafNodes();
  const GridImage incremental = gridImageOf(mapper_->slice());
  ASSERT_TRUE(saveBestMapSet(mapper_->tree(), mapper_->passBand(), &optimized.grid, incremental, dir + "/m", &written,
                             &error))
      << error;
  EXPECT_EQ(written, (std::vector<std::string>{dir + "/m.bt", dir + "/m.ot", dir + "/m.pcd", dir + "/m.pgm",
                                               dir + "/m.yaml", dir + "/m.png", dir + "/m_incremental.pgm",
                                               dir + "/m_incremental.yaml", dir + "/m_incremental.png"}));
  EXPECT_EQ(mapper_->tree().getNumLeafNodes(), leaves_before) << "saving must not change the live tree";

  // The .bt, read back with OctoMap, has the optimized cells in the band: occupied where the grid
  // is 100, free where it is 0.
  auto tree = loadTree(dir + "/m.bt", &error);
  ASSERT_TRUE(tree) << error;
  std::size_t checked = 0, agree = 0;
  const double z = 0.26;
  for (int j = 0; j < optimized.grid.height; j += 3) {
    for (int i = 0; i < optimized.grid.width; i += 3) {
      const int v = optimized.grid.at(i, j);
      if (v < 0) continue;
      const octomap::OcTreeNode* node = tree->search(optimized.grid.origin_x + (i + 0.5) * optimized.grid.resolution,
                                                     optimized.grid.origin_y + (j + 0.5) * optimized.grid.resolution, z);
      ++checked;
      if (node && tree->isNodeOccupied(node) == (v == 100)) ++agree;
    }
  }
  ASSERT_GT(checked, 1000u);
  EXPECT_EQ(agree, checked);
  GridImage pgm;
  ASSERT_TRUE(loadPgmYaml(dir + "/m.yaml", &pgm, &error)) << error;
  // The incremental slice is saved beside it, as map_server reads it.
  GridImage saved_incremental;
  ASSERT_TRUE(loadPgmYaml(dir + "/m_incremental.yaml", &saved_incremental, &error)) << error;
  EXPECT_EQ(saved_incremental.cells, trinaryOf(incremental).cells);
  // The 2D files are drawn in the incremental map's frame (which holds every cell the pass knows),
  // so that the two maps overlay cell for cell; each known cell keeps its state there.
  EXPECT_EQ(pgm.width, incremental.width);
  EXPECT_EQ(pgm.height, incremental.height);
  EXPECT_NEAR(pgm.origin_x, incremental.origin_x, 1e-6);
  EXPECT_NEAR(pgm.origin_y, incremental.origin_y, 1e-6);
  std::size_t compared = 0;
  for (int j = 0; j < optimized.grid.height; ++j) {
    for (int i = 0; i < optimized.grid.width; ++i) {
      const int v = optimized.grid.at(i, j);
      if (v < 0) continue;
      const int pi = int(std::lround((optimized.grid.origin_x - pgm.origin_x) / pgm.resolution)) + i;
      const int pj = int(std::lround((optimized.grid.origin_y - pgm.origin_y) / pgm.resolution)) + j;
      ASSERT_TRUE(pi >= 0 && pj >= 0 && pi < pgm.width && pj < pgm.height) << i << ", " << j;
      ASSERT_EQ(pgm.at(pi, pj), v) << i << ", " << j;
      ++compared;
    }
  }
  EXPECT_GT(compared, 1000u);
  std::system(("rm -rf " + dir).c_str());
}

TEST_F(OptimizedMapTest, ApplyingTheResultUpdatesTreeAndSlice) {
  Mapper mapper;
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  for (const Scan& s : session.allScans()) ASSERT_TRUE(mapper.insert(s).ok());
  const OptimizedMap optimized = mapper.optimize(/*warm_start=*/true);
  mapper.applyOptimized(optimized.grid, mapper.passBand());
  // The slice now shows the optimized state (at the clamping bounds) wherever the grid knows a cell.
  SliceGrid rebuilt(mapper.tree(), mapper.options().slice);
  rebuilt.rebuild();
  std::size_t known = 0;
  for (int j = 0; j < optimized.grid.height; ++j) {
    for (int i = 0; i < optimized.grid.width; ++i) {
      const int v = optimized.grid.at(i, j);
      if (v < 0) continue;
      const double x = optimized.grid.origin_x + (i + 0.5) * 0.05, y = optimized.grid.origin_y + (j + 0.5) * 0.05;
      const int cell = mapper.slice().valueAt(x, y);
      ASSERT_EQ(cell, rebuilt.valueAt(x, y)) << "incremental slice refresh differs from a rebuild";
      const double bound = v == 100 ? mapper.options().clamp_max : mapper.options().clamp_min;
      ASSERT_EQ(cell, std::lround(100.0 * bound)) << "at " << x << ", " << y;
      ++known;
    }
  }
  EXPECT_GT(known, 500u);

  // Mapping goes on after the result was written: the insertion cache reads the written voxels
  // back from the octree (not its stale values), so the map equals one whose octree got the same
  // updates directly.
  octomap::OcTree direct(mapper.tree());
  ScanInserter plain(&direct, InsertOptions{});
  const auto scans = session.allScans();
  for (std::size_t k = 0; k < scans.size(); k += 7) {
    ASSERT_TRUE(mapper.insert(scans[k]).ok());
    ASSERT_TRUE(plain.insert(scans[k]).ok());
  }
  plain.flush();
  const octomap::OcTree& live = mapper.tree();
  ASSERT_EQ(live.getNumLeafNodes(), direct.getNumLeafNodes());
  for (auto it = direct.begin_leafs(); it != direct.end_leafs(); ++it) {
    const octomap::OcTreeNode* node = live.search(it.getKey(), it.getDepth());
    ASSERT_NE(node, nullptr);
    ASSERT_EQ(node->getLogOdds(), it->getLogOdds());
  }
}

// With the depth camera the band is the navigation band, and a table top above the
// lidar's plane is the camera's evidence. The global pass explains the lidar's beams, which pass
// under the table: its result must neither erase the table top from the octree nor hide it.
TEST(OptimizedMapWithCameraTest, ObstaclesAboveTheLidarPlaneSurviveThePass) {
  MapperOptions options;
  options.slice.min_z = 0.05;
  options.slice.max_z = 0.80;
  Mapper mapper(options);
  const sim::FloorPlan plan = sim::FloorPlan::office();
  const sim::SimulatedSession session(plan, sim::SessionSpec::officeTour());
  const sim::BoxScene scene = sim::BoxScene::of(plan);
  const sim::CameraMount mount;
  std::mt19937 rng(3);
  double next_frame = 0.0;
  for (const Scan& s : session.allScans()) {
    ASSERT_TRUE(mapper.insert(s).ok());
    if (s.stamp < next_frame) continue;
    next_frame = s.stamp + 1.0 / mount.rate_hz;
    const sim::Pose2D p = session.poseAt(s.stamp);
    const Eigen::Isometry3d pose = sim::opticalOnRobot(mount, p.x, p.y, p.yaw);
    std::vector<Eigen::Vector3f> points = sim::depthFrame(scene, pose, mount.spec, &rng);
    for (Eigen::Vector3f& q : points) q = (pose.cast<float>() * q).eval();
    ASSERT_TRUE(mapper.insertPoints(pose.translation(), points).ok());
  }
  // The table top's centre (9.6, 6.0): occupied in the incremental slice, and in the octree in
  // one of the voxel layers the 0.69-0.72 m top spans (0.65-0.70 or 0.70-0.75 m).
  const auto occupiedAt = [&](const Eigen::Vector3d& q) {
    const octomap::OcTreeNode* n = mapper.tree().search(q.x(), q.y(), q.z());
    return n && mapper.tree().isNodeOccupied(n);
  };
  const Eigen::Vector3d top = occupiedAt({9.6, 6.0, 0.705}) ? Eigen::Vector3d(9.6, 6.0, 0.705) : Eigen::Vector3d(9.6, 6.0, 0.675);
  ASSERT_GT(mapper.slice().valueAt(top.x(), top.y()), 65);
  ASSERT_TRUE(occupiedAt(top));
  const PassBand band = mapper.passBand();
  EXPECT_EQ(band.scans_lo, band.scans_hi) << "a level lidar's scans are taken in one layer";
  EXPECT_FALSE(obstaclesBesidePass(mapper.tree(), band).empty());

  const OptimizedMap optimized = mapper.optimize(/*warm_start=*/true);
  int i = int(std::floor((top.x() - optimized.grid.origin_x) / 0.05)), j = int(std::floor((top.y() - optimized.grid.origin_y) / 0.05));
  ASSERT_LT(optimized.grid.at(i, j), 50) << "the lidar's beams pass under the table: the pass alone calls it free";
  // What ~optimized_map shows: the pass's grid with the cells beside it occupied: the table top,
  // and exactly the cells the saved optimized set marks (one rule for both, also for columns whose
  // lidar layer is occupied too, such as the table's legs).
  const GridImage frame = gridImageOf(mapper.slice());
  const std::vector<std::size_t> beside = mapper.cellsBesidePass(frame);
  const auto cellOf = [&](double x, double y) {
    return std::size_t(std::floor((y - frame.origin_y) / 0.05)) * frame.width + std::size_t(std::floor((x - frame.origin_x) / 0.05));
  };
  EXPECT_TRUE(std::count(beside.begin(), beside.end(), cellOf(top.x(), top.y())));
  std::set<std::size_t> saved_rule;
  for (const octomap::OcTreeKey& k : obstaclesBesidePass(mapper.tree(), band)) {
    saved_rule.insert(cellOf(mapper.tree().keyToCoord(k[0]), mapper.tree().keyToCoord(k[1])));
  }
  EXPECT_EQ(std::set<std::size_t>(beside.begin(), beside.end()), saved_rule);
  std::size_t lidar_seen_too = 0;  // columns with an occupied lidar-layer voxel as well
  for (std::size_t c : saved_rule) {
    const double x = frame.origin_x + (c % frame.width + 0.5) * 0.05, y = frame.origin_y + (c / frame.width + 0.5) * 0.05;
    const octomap::OcTreeNode* n = mapper.tree().search(x, y, 0.26);
    lidar_seen_too += n && mapper.tree().isNodeOccupied(n);
  }
  EXPECT_GT(lidar_seen_too, 0u) << "the case the two rules differed on is in this map";
  const GridImage shown = withObstacles(inFrameOf(optimized.grid, frame), frame, beside);
  EXPECT_EQ(shown.cells[cellOf(top.x(), top.y())], 100);

  char tmpl[] = "/tmp/osm_optimized_camera_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(saveBestMapSet(mapper.tree(), band, &optimized.grid, gridImageOf(mapper.slice()), dir + "/m", &written,
                             &error))
      << error;
  GridImage saved;
  ASSERT_TRUE(loadPgmYaml(dir + "/m.yaml", &saved, &error)) << error;
  i = int(std::floor((top.x() - saved.origin_x) / saved.resolution)), j = int(std::floor((top.y() - saved.origin_y) / saved.resolution));
  EXPECT_GT(saved.at(i, j), 65) << "the saved optimized map shows the table top";
  octomap::OcTree bt(0.05);
  ASSERT_TRUE(bt.readBinary(dir + "/m.bt"));
  const octomap::OcTreeNode* in_bt = bt.search(top.x(), top.y(), top.z());
  EXPECT_TRUE(in_bt && bt.isNodeOccupied(in_bt)) << "the .bt with the pass's result kept the table top";
  std::system(("rm -rf " + dir).c_str());

  mapper.applyOptimized(optimized.grid, band);
  EXPECT_TRUE(occupiedAt(top)) << "the pass's result written into the octree kept the table top";
  EXPECT_GT(mapper.slice().valueAt(top.x(), top.y()), 65);
  // Under the table, in the lidar's layer, the pass's free result went in.
  const octomap::OcTreeNode* under = mapper.tree().search(top.x(), top.y(), 0.26);
  ASSERT_NE(under, nullptr);
  EXPECT_FALSE(mapper.tree().isNodeOccupied(under));
}

// A result replaces the one before in full: the pass writes only the layers it speaks for, so a
// wall the first result wrote cannot stay behind as if another sensor had seen it.
TEST(OptimizedMapApplyTest, ASecondResultReplacesTheFirst) {
  Mapper mapper;
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  for (const Scan& s : session.allScans()) ASSERT_TRUE(mapper.insert(s).ok());
  GridImage grid = mapper.optimize(/*warm_start=*/true).grid;
  std::size_t cell = grid.cells.size();
  for (std::size_t c = 0; c < grid.cells.size() && cell == grid.cells.size(); ++c) {
    if (grid.cells[c] == 0) cell = c;  // a free cell
  }
  ASSERT_LT(cell, grid.cells.size());
  const double x = grid.origin_x + (double(cell % grid.width) + 0.5) * grid.resolution;
  const double y = grid.origin_y + (double(cell / grid.width) + 0.5) * grid.resolution;
  grid.cells[cell] = 100;
  mapper.applyOptimized(grid, mapper.passBand());
  ASSERT_GT(mapper.slice().valueAt(x, y), 65);
  grid.cells[cell] = 0;
  mapper.applyOptimized(grid, mapper.passBand());
  EXPECT_LT(mapper.slice().valueAt(x, y), 50);
  for (double z = mapper.options().slice.min_z; z <= mapper.options().slice.max_z; z += 0.05) {
    const octomap::OcTreeNode* node = mapper.tree().search(x, y, z);
    EXPECT_FALSE(node && mapper.tree().isNodeOccupied(node)) << "z " << z;
  }
}

}  // namespace
