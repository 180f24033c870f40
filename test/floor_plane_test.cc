// The frame's floor by PCL's sample consensus: the lowest supported level plane, seeded, and none
// where a frame shows no floor.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "octo_slice_mapper/internal/floor_plane.h"

using namespace octo_slice_mapper;

namespace {

// Samples of a surface z = z0 + slope_x x over [x0, x1] x [y0, y1], every `step` m, with noise.
void addPlane(std::vector<Eigen::Vector3d>* samples, double x0, double x1, double y0, double y1, double z0,
              double slope_x, double step, std::mt19937* rng, double noise = 0.01) {
  std::normal_distribution<double> gauss(0.0, noise);
  for (double x = x0; x <= x1; x += step) {
    for (double y = y0; y <= y1; y += step) samples->emplace_back(x, y, z0 + slope_x * x + gauss(*rng));
  }
}

// A wall at x = x_wall from the floor up.
void addWall(std::vector<Eigen::Vector3d>* samples, double x_wall, double z0, double z1, std::mt19937* rng) {
  std::normal_distribution<double> gauss(0.0, 0.01);
  for (double y = 0.0; y <= 3.0; y += 0.05) {
    for (double z = z0; z <= z1; z += 0.05) samples->emplace_back(x_wall + gauss(*rng), y, z);
  }
}

}  // namespace

TEST(FloorPlane, FindsTheFloorWhereverTheFixedFrameHasIt) {
  for (double floor : {0.0, -1.5, 0.7}) {
    std::mt19937 rng(1);
    std::vector<Eigen::Vector3d> samples;
    addPlane(&samples, 0.0, 3.0, 0.0, 3.0, floor, 0.0, 0.05, &rng);
    addWall(&samples, 3.0, floor, floor + 2.0, &rng);
    const std::optional<FloorFit> fit = fitFloor(samples, Eigen::Vector3d(0.0, 1.5, floor + 1.2), std::nullopt, {});
    ASSERT_TRUE(fit) << floor;
    EXPECT_NEAR(fit->plane.heightAt(1.0, 1.0), floor, 0.01);
    EXPECT_LT(fit->plane.tilt(), 0.01);
    // Every floor sample is an inlier, no wall sample above the floor's band is.
    for (std::size_t i : fit->inliers) EXPECT_LT(std::abs(samples[i].z() - floor), 0.05);
    EXPECT_GT(fit->inliers.size(), 3000u);
  }
}

TEST(FloorPlane, TheLowestSupportedPlaneWinsOverATableTop) {
  std::mt19937 rng(2);
  std::vector<Eigen::Vector3d> samples;
  addPlane(&samples, 0.0, 3.0, 0.0, 3.0, 0.72, 0.0, 0.03, &rng);  // a big table top, dense
  addPlane(&samples, 3.0, 4.0, 0.0, 3.0, 0.0, 0.0, 0.05, &rng);   // the floor beside it
  const std::optional<FloorFit> fit = fitFloor(samples, Eigen::Vector3d(2.0, 1.5, 1.5), std::nullopt, {});
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->plane.heightAt(3.5, 1.0), 0.0, 0.02);
}

// A low camera sees the floor, an 8 cm step across its whole view, the step's shadow and the floor
// beyond. The step's top is not floor: a plane between the two surfaces, a little off level, would
// hold both within a wider band (at an inlier distance of 0.04 m, 18 of these 20 frames).
TEST(FloorPlane, ALowStepAcrossTheViewIsNotTakenForFloor) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    std::vector<Eigen::Vector3d> samples;
    addPlane(&samples, 0.5, 1.45, -1.5, 1.5, 0.0, 0.0, 0.05, &rng);  // the floor up to the step
    addPlane(&samples, 1.5, 2.5, -1.5, 1.5, 0.08, 0.0, 0.05, &rng);  // the step's top
    addPlane(&samples, 3.1, 4.0, -1.5, 1.5, 0.0, 0.0, 0.05, &rng);   // the floor beyond its shadow
    const std::optional<FloorFit> fit = fitFloor(samples, Eigen::Vector3d(0.0, 0.0, 0.35), std::nullopt, {});
    ASSERT_TRUE(fit) << seed;
    EXPECT_NEAR(fit->plane.heightAt(2.0, 0.0), 0.0, 0.02) << seed;
    std::size_t on_step = 0;
    for (std::size_t i : fit->inliers) on_step += samples[i].x() > 1.47 && samples[i].x() < 2.53;
    EXPECT_EQ(on_step, 0u) << seed;
  }
}

// A low camera sees a strip of floor and an 8 or 10 cm step whose top fills the rest of its view:
// the step's top is the plane found first (three times the floor's samples), and the floor in
// front of it, 8 or 10 cm below, is taken over it, with or without the floor as the seed.
TEST(FloorPlane, AStepFillingTheViewGivesWayToTheFloorInFrontOfIt) {
  for (const bool seeded : {false, true}) {
    for (const double step : {0.08, 0.10}) {
      for (unsigned seed = 1; seed <= 20; ++seed) {
        std::mt19937 rng(seed);
        std::vector<Eigen::Vector3d> samples;
        addPlane(&samples, 0.5, 1.2, -1.5, 1.5, 0.0, 0.0, 0.05, &rng);    // the floor up to the step
        const std::size_t floor_samples = samples.size();
        addPlane(&samples, 1.25, 3.5, -1.5, 1.5, step, 0.0, 0.05, &rng);  // the step's top
        const std::size_t step_samples = samples.size() - floor_samples;
        const std::optional<FloorPlane> last =
            seeded ? std::optional<FloorPlane>(FloorPlane{Eigen::Vector3d::UnitZ(), 0.0}) : std::nullopt;
        const std::optional<FloorFit> fit = fitFloor(samples, Eigen::Vector3d(0.0, 0.0, 0.35), last, {});
        ASSERT_TRUE(fit) << seed;
        EXPECT_NEAR(fit->plane.heightAt(1.0, 0.0), 0.0, 0.015) << seeded << " " << step << " " << seed;
        // (The strip's plane, followed 2 m beyond it, may graze the far edge of the step's top.)
        std::size_t on_step = 0;
        for (std::size_t i : fit->inliers) on_step += samples[i].x() > 1.22;
        EXPECT_LT(on_step, step_samples / 50) << seeded << " " << step << " " << seed;
      }
    }
  }
}

// A robot's low camera 2 m before a wide low step sees the floor up to it and the step's top: a
// plane tilted about 2 degrees holds the far floor and the top's near part within its band (two
// level runs along its slope, with a jump between them), and the floor is refitted under it.
TEST(FloorPlane, APlaneAcrossAStepsEdgeIsTwoSurfacesAndTheFloorIsTheLower) {
  for (const double step : {0.06, 0.08}) {
    for (unsigned seed = 1; seed <= 20; ++seed) {
      std::mt19937 rng(seed);
      std::vector<Eigen::Vector3d> samples;
      addPlane(&samples, 0.7, 1.95, 0.0, 2.0, 0.0, 0.0, 0.05, &rng, 0.005);   // the floor up to the step
      addPlane(&samples, 2.0, 3.95, 0.0, 2.0, step, 0.0, 0.05, &rng, 0.005);  // the step's top
      const std::optional<FloorFit> fit = fitFloor(samples, Eigen::Vector3d(0.0, 1.0, 0.35), std::nullopt, {});
      ASSERT_TRUE(fit) << step << " " << seed;
      EXPECT_LT(fit->plane.tilt(), 0.01) << step << " " << seed;
      EXPECT_NEAR(fit->plane.heightAt(1.5, 1.0), 0.0, 0.01) << step << " " << seed;
      std::size_t on_step = 0;
      for (std::size_t i : fit->inliers) on_step += samples[i].x() > 1.97;
      EXPECT_EQ(on_step, 0u) << step << " " << seed;
    }
  }
}

// A robot's ground point (its base_footprint) names the floor it stands on: at a stairwell's edge
// the landing below, which holds more of the view and is the lowest plane, is not it; on a floor
// under a table top that fills most of the view, the floor still is; and a frame that shows only
// the landing has no floor.
TEST(FloorPlane, AGroundPointKeepsTheFloorTheRobotStandsOn) {
  std::mt19937 rng(11);
  std::vector<Eigen::Vector3d> edge;
  addPlane(&edge, 0.0, 1.5, 0.0, 2.0, 0.0, 0.0, 0.05, &rng);
  addPlane(&edge, 1.55, 4.0, 0.0, 2.0, -1.0, 0.0, 0.05, &rng);
  const Eigen::Vector3d sensor(0.0, 1.0, 0.35), ground(0.0, 1.0, 0.0);
  const std::optional<FloorFit> free_fit = fitFloor(edge, sensor, std::nullopt, {});
  ASSERT_TRUE(free_fit);
  EXPECT_NEAR(free_fit->plane.heightAt(0.0, 1.0), -1.0, 0.02);  // the lowest plane, without the ground
  for (const std::optional<FloorPlane>& seed : {std::optional<FloorPlane>(), std::optional<FloorPlane>(free_fit->plane)}) {
    const std::optional<FloorFit> fit = fitFloor(edge, sensor, seed, {}, ground, 0.05);
    ASSERT_TRUE(fit);
    EXPECT_NEAR(fit->plane.heightAt(0.0, 1.0), 0.0, 0.02);
    EXPECT_NEAR(fit->plane.heightAt(3.0, 1.0), 0.0, 0.03);
  }
  std::vector<Eigen::Vector3d> table;
  addPlane(&table, 0.5, 3.0, 0.0, 3.0, 0.72, 0.0, 0.05, &rng);
  addPlane(&table, 0.0, 0.45, 0.0, 3.0, 0.0, 0.0, 0.05, &rng);
  const std::optional<FloorFit> under = fitFloor(table, Eigen::Vector3d(-0.5, 1.5, 1.2), std::nullopt, {},
                                                 Eigen::Vector3d(-0.5, 1.5, 0.0), 0.05);
  ASSERT_TRUE(under);
  EXPECT_NEAR(under->plane.heightAt(0.2, 1.5), 0.0, 0.02);
  std::vector<Eigen::Vector3d> landing;
  addPlane(&landing, 1.55, 4.0, 0.0, 2.0, -1.0, 0.0, 0.05, &rng);
  EXPECT_FALSE(fitFloor(landing, sensor, std::nullopt, {}, ground, 0.05));
  EXPECT_TRUE(fitFloor(landing, sensor, std::nullopt, {}));
}

TEST(FloorPlane, ATiltedFloorWithinTheToleranceIsFoundAndASteeperSlopeIsNot) {
  std::mt19937 rng(3);
  FloorFitOptions options;
  std::vector<Eigen::Vector3d> ramp;
  addPlane(&ramp, 0.0, 3.0, 0.0, 3.0, 0.0, std::tan(0.05), 0.05, &rng);  // 2.9 degrees
  const std::optional<FloorFit> fit = fitFloor(ramp, Eigen::Vector3d(0.0, 1.5, 1.0), std::nullopt, options);
  ASSERT_TRUE(fit);
  EXPECT_NEAR(fit->plane.tilt(), 0.05, 0.01);
  EXPECT_NEAR(fit->plane.heightAt(2.0, 1.0), 2.0 * std::tan(0.05), 0.01);
  // A slope steeper than the tolerance is never taken whole: at most a level strip across it.
  std::vector<Eigen::Vector3d> steep;
  addPlane(&steep, 0.0, 3.0, 0.0, 3.0, 0.0, std::tan(options.max_tilt + 0.1), 0.05, &rng);
  const std::optional<FloorFit> strip = fitFloor(steep, Eigen::Vector3d(0.0, 1.5, 1.0), std::nullopt, options);
  if (strip) {
    EXPECT_LE(strip->plane.tilt(), options.max_tilt);
    EXPECT_LT(strip->inliers.size(), steep.size() / 3);
  }
}

TEST(FloorPlane, AFrameOfWallsOrTooFewFloorReturnsHasNone) {
  std::mt19937 rng(4);
  std::vector<Eigen::Vector3d> walls;
  addWall(&walls, 2.0, 0.0, 2.0, &rng);
  addWall(&walls, 3.0, 0.0, 2.0, &rng);
  EXPECT_FALSE(fitFloor(walls, Eigen::Vector3d(0.0, 1.5, 1.2), std::nullopt, {}));
  std::vector<Eigen::Vector3d> patch;  // 0.3 x 0.3 m: 49 samples, fewer than min_points
  addPlane(&patch, 1.0, 1.3, 1.0, 1.3, 0.0, 0.0, 0.05, &rng);
  EXPECT_FALSE(fitFloor(patch, Eigen::Vector3d(0.0, 1.5, 1.2), std::nullopt, {}));
  EXPECT_FALSE(fitFloor({}, Eigen::Vector3d::Zero(), std::nullopt, {}));
}

TEST(FloorPlane, APlaneAtTheSensorsHeightIsNoFloor) {
  std::mt19937 rng(5);
  std::vector<Eigen::Vector3d> samples;
  addPlane(&samples, 0.0, 3.0, 0.0, 3.0, 1.0, 0.0, 0.05, &rng);  // level with the sensor: a ceiling seen edge-on
  EXPECT_FALSE(fitFloor(samples, Eigen::Vector3d(0.0, 1.5, 1.05), std::nullopt, {}));
}

TEST(FloorPlane, TheSameSamplesGiveTheSamePlane) {
  std::mt19937 rng(6);
  std::vector<Eigen::Vector3d> samples;
  addPlane(&samples, 0.0, 4.0, 0.0, 4.0, -0.3, 0.01, 0.05, &rng, 0.02);
  addWall(&samples, 4.0, -0.3, 1.5, &rng);
  const std::optional<FloorFit> a = fitFloor(samples, Eigen::Vector3d(0.0, 2.0, 1.0), std::nullopt, {});
  const std::optional<FloorFit> b = fitFloor(samples, Eigen::Vector3d(0.0, 2.0, 1.0), std::nullopt, {});
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->plane.normal, b->plane.normal);
  EXPECT_EQ(a->plane.d, b->plane.d);
  EXPECT_EQ(a->inliers, b->inliers);
}
