// The floor layer: the floor found per frame and kept per cell, where it came from, what it
// refuses (a table top above a known floor), and the view a frame is measured against.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "octo_slice_mapper/internal/floor_layer.h"

using namespace octo_slice_mapper;

namespace {

constexpr double kResolution = 0.05;

// End-voxel-like samples of a level surface at z over [x0, x1] x [y0, y1].
void addSurface(std::vector<Eigen::Vector3d>* samples, double x0, double x1, double y0, double y1, double z) {
  std::mt19937 rng(static_cast<unsigned>(samples->size() + 1));
  std::normal_distribution<double> gauss(0.0, 0.005);
  for (double x = x0 + 0.025; x < x1; x += kResolution) {
    for (double y = y0 + 0.025; y < y1; y += kResolution) samples->emplace_back(x, y, z + gauss(rng));
  }
}

std::vector<Eigen::Vector3d> floorFrame(double floor, double x0 = 0.0, double x1 = 2.0) {
  std::vector<Eigen::Vector3d> samples;
  addSurface(&samples, x0, x1, 0.0, 2.0, floor);
  return samples;
}

}  // namespace

TEST(FloorLayer, WithNoFloorEverFoundTheFloorIsTheFixedFramesZero) {
  FloorLayer layer(kResolution, {});
  std::vector<Eigen::Vector3d> wall;
  for (double z = 0.0; z < 2.0; z += 0.05) {
    for (double y = 0.0; y < 2.0; y += 0.05) wall.emplace_back(3.0, y, z);
  }
  const FloorView view = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), wall, 10.0);
  EXPECT_EQ(view.heightAt(1.0, 1.0), 0.0);
  EXPECT_EQ(layer.status().source, FloorSource::kAssumed);
  EXPECT_EQ(layer.status().frames_without, 1u);
  EXPECT_FALSE(layer.takeLevelChanges().fallback_changed);
  EXPECT_EQ(FloorView().heightAt(5.0, 5.0), 0.0);
}

TEST(FloorLayer, AFloorFoundIsKeptPerCellAndByFramesThatSeeNone) {
  FloorLayer layer(kResolution, {});
  const FloorView first = layer.observe(Eigen::Vector3d(0.0, 1.0, 0.0), floorFrame(-1.5), 10.0);
  EXPECT_NEAR(first.heightAt(1.0, 1.0), -1.5, 0.01);
  EXPECT_EQ(layer.status().source, FloorSource::kFound);
  EXPECT_NEAR(layer.status().height, -1.5, 0.01);
  EXPECT_EQ(layer.status().cells, 40u * 40u);
  FloorLayer::LevelChanges changes = layer.takeLevelChanges();
  EXPECT_TRUE(changes.fallback_changed);
  EXPECT_EQ(changes.fallback_level, -30);
  EXPECT_EQ(changes.cells.size(), 40u * 40u);
  EXPECT_EQ(changes.cells.front().second, -30);
  EXPECT_TRUE(layer.takeLevelChanges().cells.empty());  // taken once

  const FloorView next = layer.observe(Eigen::Vector3d(0.0, 1.0, 0.0), {}, 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  EXPECT_NEAR(next.heightAt(1.0, 1.0), -1.5, 0.01);
  EXPECT_NEAR(next.heightAt(8.0, 1.0), -1.5, 0.01);  // beyond the cells: the last plane, level there
}

TEST(FloorLayer, ATableTopAboveAKnownFloorIsNotTheFloor) {
  FloorLayer layer(kResolution, {});
  layer.observe(Eigen::Vector3d(0.0, 1.0, 1.2), floorFrame(0.0), 10.0);
  std::vector<Eigen::Vector3d> table;
  addSurface(&table, 0.5, 2.0, 0.0, 2.0, 0.72);
  const FloorView view = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.2), table, 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  EXPECT_NEAR(view.heightAt(1.0, 1.0), 0.0, 0.01);
  // A step of a few centimetres up (a ramp's next frame) is floor.
  layer.observe(Eigen::Vector3d(1.0, 1.0, 1.2), floorFrame(0.04, 1.0, 3.0), 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kFound);
}

TEST(FloorLayer, ALowerFloorFoundLaterUndoesATableTakenForTheFloor) {
  FloorLayer layer(kResolution, {});
  std::vector<Eigen::Vector3d> table;
  addSurface(&table, 0.0, 1.5, 0.0, 2.0, 0.72);
  layer.observe(Eigen::Vector3d(0.0, 1.0, 1.5), table, 10.0);  // nothing better seen yet
  EXPECT_NEAR(layer.status().height, 0.72, 0.02);
  layer.takeLevelChanges();
  std::vector<Eigen::Vector3d> both = floorFrame(0.0, 1.5, 3.5);
  const FloorView view = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.5), both, 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kFound);
  EXPECT_NEAR(view.heightAt(2.5, 1.0), 0.0, 0.01);
  EXPECT_NEAR(view.heightAt(0.5, 1.0), 0.0, 0.01);  // the table's cells forgotten: the new plane
  bool forgotten = false;
  for (const auto& change : layer.takeLevelChanges().cells) forgotten = forgotten || change.second == FloorLayer::kNoLevel;
  EXPECT_TRUE(forgotten);
}

TEST(FloorLayer, AViewKeepsTheFloorAsOfItsFrame) {
  FloorLayer layer(kResolution, {});
  const FloorView before = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), floorFrame(0.0), 10.0);
  FloorOptions options;
  options.memory_frames = 1;
  layer.setOptions(options);
  layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), floorFrame(0.06), 10.0);  // the same cells, 6 cm up
  EXPECT_NEAR(before.heightAt(1.0, 1.0), 0.0, 0.01);
  const FloorView after = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), {}, 10.0);
  EXPECT_NEAR(after.heightAt(1.0, 1.0), 0.03, 0.01);  // the mean of the two frames
}

TEST(FloorLayer, ResetForgetsEverything) {
  FloorLayer layer(kResolution, {});
  layer.observe(Eigen::Vector3d(0.0, 1.0, 0.0), floorFrame(-1.5), 10.0);
  layer.takeLevelChanges();
  layer.reset(kResolution);
  EXPECT_EQ(layer.status().cells, 0u);
  EXPECT_EQ(layer.status().source, FloorSource::kAssumed);
  const FloorLayer::LevelChanges changes = layer.takeLevelChanges();
  EXPECT_TRUE(changes.fallback_changed);
  EXPECT_EQ(changes.fallback_level, 0);
  int cells = 0;
  layer.forEachCell([&](std::uint16_t, std::uint16_t, float) { ++cells; });
  EXPECT_EQ(cells, 0);
}
