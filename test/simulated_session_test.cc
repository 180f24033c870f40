// The whole simulated TurtleBot session mapped in-process, scored against the floor plan.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "../bench/peer_maps.h"  // the peers, as bench_map_quality builds them
#include "octo_slice_mapper/held_out_score.h"
#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

using namespace octo_slice_mapper;

class SimulatedSessionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    session_ = new sim::SimulatedSession(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
    mapper_ = new Mapper();
    for (const Scan& scan : session_->allScans()) {
      const InsertResult r = mapper_->insert(scan);
      ASSERT_TRUE(r.ok()) << r.error;
    }
  }
  static void TearDownTestSuite() {
    delete mapper_;
    delete session_;
  }
  static sim::SimulatedSession* session_;
  static Mapper* mapper_;
};
sim::SimulatedSession* SimulatedSessionTest::session_ = nullptr;
Mapper* SimulatedSessionTest::mapper_ = nullptr;

TEST_F(SimulatedSessionTest, SessionIsAHokuyoLikeRun) {
  const auto scans = session_->allScans();
  ASSERT_GT(scans.size(), 500u);
  EXPECT_EQ(scans.front().ranges.size(), 682u);
  EXPECT_NEAR((scans.front().ranges.size() - 1) * scans.front().angle_increment, 240.0 * M_PI / 180.0, 0.02);
  EXPECT_NEAR(scans.front().sensor_pose.translation().z(), 0.26, 1e-9);
  const MapperStats& s = mapper_->stats();
  EXPECT_GT(s.readings[ReadingKind::kNoReturn], 0u);
  EXPECT_GT(s.readings[ReadingKind::kNaN], 0u);
  EXPECT_GT(s.readings[ReadingKind::kBelowMin], 0u);
}

TEST_F(SimulatedSessionTest, MapMatchesGroundTruth) {
  const GridImage truth = session_->plan().groundTruth(0.05);
  const GridImage map = gridImageOf(mapper_->slice());
  const OccupancyScore score = scoreOccupancy(map, truth, 1);
  std::printf("[ simulated session ] precision %.4f recall %.4f (map occupied %zu, truth observed %zu)\n",
              score.precision, score.recall, score.map_occupied, score.truth_observed);
  EXPECT_GE(score.precision, 0.90);
  EXPECT_GE(score.recall, 0.90);
  EXPECT_GT(score.truth_observed, 2000u) << "the tour must see most of the walls";
}

TEST_F(SimulatedSessionTest, OpenDoorsAreFreeAndWallsBesideThemOccupied) {
  const SliceGrid& slice = mapper_->slice();
  for (const sim::Door& door : session_->plan().doors) {
    const Eigen::Vector2d mid = 0.5 * (door.a + door.b);
    EXPECT_GE(slice.valueAt(mid.x(), mid.y()), 0) << door.name << " observed";
    EXPECT_LT(slice.valueAt(mid.x(), mid.y()), 50) << door.name << " doorway should be free";
  }
}

TEST_F(SimulatedSessionTest, WalkingPersonLeavesNoTrail) {
  // The person walked along y = 1.6 between x = 3.5 and 12.5; the robot drove the corridor at the end.
  int occupied = 0, observed = 0;
  for (double x = 4.0; x < 12.0; x += 0.05) {
    const int v = mapper_->slice().valueAt(x, 1.6);
    if (v >= 0) ++observed;
    if (v > 50) ++occupied;
  }
  EXPECT_GT(observed, 100);
  EXPECT_LT(occupied, observed / 20) << "at most 5 % of the person's path may still look occupied";
}

namespace {

// The issue-18 judgement: every 10th scan from index 5 held out, the rest mapped with the
// defaults, each map read as map_server reads its .pgm, the held-out returns cast through it
// (share within 0.10 m); ours and the peers, as bench_map_quality gives them.
struct HeldOutFigures {
  double incremental = 0, optimized = 0, hit_miss_grid = 0, octomap_server = 0;
  std::size_t held_scans = 0;
};
HeldOutFigures judgeHeldOut(const std::vector<Scan>& scans, const char* label) {
  const HoldOut hold{10, 5};
  std::vector<Scan> train, held;
  for (std::size_t k = 0; k < scans.size(); ++k) (hold.holds(k) ? held : train).push_back(scans[k]);
  const MapperOptions options;
  Mapper mapper(options);
  for (const Scan& s : train) EXPECT_TRUE(mapper.insert(s).ok());
  const GridImage incremental = gridImageOf(mapper.slice());
  const GridImage optimized = inFrameOf(mapper.optimize(/*warm_start=*/true).grid, incremental);
  const auto within = [&](const GridImage& grid) { return scoreHeldOut(trinaryOf(grid), held).within_10cm; };
  HeldOutFigures f;
  f.incremental = within(incremental);
  f.optimized = within(optimized);
  f.hit_miss_grid = within(bench::hitMissGrid(train, options.resolution, /*max_likelihood=*/true));
  f.octomap_server =
      within(bench::octomapServerMap(train, options.resolution, options.slice.min_z, options.slice.max_z));
  f.held_scans = held.size();
  std::printf("[ held out, %s ] incremental %.4f, optimized %.4f, hit/miss grid %.4f, octomap_server %.4f\n", label,
              f.incremental, f.optimized, f.hit_miss_grid, f.octomap_server);
  return f;
}

// The tour moved by `shift` in x and y (0.025: its walls, on round coordinates, inside cells).
std::vector<Scan> moved(std::vector<Scan> scans, double shift) {
  for (Scan& s : scans) s.sensor_pose.translation() += Eigen::Vector3d(shift, shift, 0.0);
  return scans;
}

}  // namespace

// On data no setting was chosen on, with exact poses: the global pass's map must be as good as the
// plain hit/miss grid (max-likelihood) within 0.005, and the incremental slice better than
// octomap_server's method; with the tour as simulated (its walls on cell boundaries) and moved by
// half a cell (walls inside cells, as a real building's mostly are).
// (The incremental slice is below the grid with exact poses, ahead of it with a corrected log's
// pose errors (the test below); not asserted.)
TEST_F(SimulatedSessionTest, OnHeldOutScansTheOptimizedMapMatchesTheHitMissGrid) {
  const std::vector<Scan> scans = session_->allScans();  // simulated once, moved per case
  for (const double shift : {0.0, 0.025}) {
    const HeldOutFigures f = judgeHeldOut(moved(scans, shift), shift == 0.0 ? "as simulated" : "moved half a cell");
    EXPECT_GE(f.optimized, f.hit_miss_grid - 0.005) << "moved " << shift;
    EXPECT_GT(f.incremental, f.octomap_server) << "moved " << shift;
    EXPECT_GT(f.held_scans, 100u);
  }
}

// With a corrected log's pose errors (each scan's recorded pose 3 cm and 1 deg off, sigma), the
// peers' walls blur and ours must not: the incremental slice ahead of both peers and the pass's
// map ahead of the better one by 0.05, as on the real logs (with exact poses the grid wins, the
// test above).
TEST_F(SimulatedSessionTest, WithACorrectedLogsPoseErrorsOurMapsBeatBothPeers) {
  std::vector<Scan> scans = moved(session_->allScans(), 0.025);
  sim::PoseErrors errors;
  errors.sigma_xy = 0.03;
  errors.sigma_yaw = 1.0 * M_PI / 180.0;
  sim::addPoseErrors(&scans, errors);
  const HeldOutFigures f = judgeHeldOut(scans, "pose errors");
  const double best_peer = std::max(f.hit_miss_grid, f.octomap_server);
  EXPECT_GT(f.incremental, best_peer);
  EXPECT_GE(f.optimized, best_peer + 0.05);
}

TEST(PoseErrors, AreIndependentPerScanWithTheGivenSpreadAndKeepTheReadings) {
  std::vector<Scan> scans(4000);
  for (Scan& s : scans) {
    s.sensor_pose = Eigen::Isometry3d::Identity();
    s.sensor_pose.translation() = Eigen::Vector3d(1.0, 2.0, 0.26);
    s.ranges = {1.0f, 2.0f};
  }
  sim::PoseErrors errors;
  errors.sigma_xy = 0.02;
  errors.sigma_yaw = 0.01;
  sim::addPoseErrors(&scans, errors);
  double sx = 0, sxx = 0, syaw = 0, syy = 0, lag = 0;
  double previous = 0.0;
  for (const Scan& s : scans) {
    const double dx = s.sensor_pose.translation().x() - 1.0;
    const double yaw = std::atan2(s.sensor_pose.linear()(1, 0), s.sensor_pose.linear()(0, 0));
    sx += dx, sxx += dx * dx, syaw += yaw, syy += yaw * yaw, lag += dx * previous;
    previous = dx;
    EXPECT_DOUBLE_EQ(s.sensor_pose.translation().z(), 0.26);
    EXPECT_EQ(s.ranges, (std::vector<float>{1.0f, 2.0f}));
  }
  const double n = double(scans.size());
  EXPECT_NEAR(sx / n, 0.0, 0.002);
  EXPECT_NEAR(std::sqrt(sxx / n), 0.02, 0.002);
  EXPECT_NEAR(syaw / n, 0.0, 0.001);
  EXPECT_NEAR(std::sqrt(syy / n), 0.01, 0.001);
  EXPECT_NEAR(lag / n / (sxx / n), 0.0, 0.1);  // no correlation from one scan to the next
}
