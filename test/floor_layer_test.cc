// The floor layer: the floor found per frame and kept per cell, where it came from, what it
// refuses (a table top above a known floor), and the view a frame is measured against.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <tuple>

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

// The process's peak resident memory (kB, Linux's VmHWM), or -1 where it cannot be read.
long peakResidentKb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
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

  // Frames are measured against the layer kLag frames before them: the next one (which a
  // pipeline may prepare at the same time) does not see the floor yet, the kLag-th does.
  FloorView next;
  for (std::uint64_t k = 1; k <= FloorLayer::kLag; ++k) {
    next = layer.observe(Eigen::Vector3d(0.0, 1.0, 0.0), {}, 10.0);
    if (k < FloorLayer::kLag) {
      EXPECT_EQ(next.heightAt(1.0, 1.0), 0.0) << "frame " << k;
    }
  }
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  EXPECT_NEAR(next.heightAt(1.0, 1.0), -1.5, 0.01);
  EXPECT_NEAR(next.heightAt(8.0, 1.0), -1.5, 0.01);  // beyond the cells: the last plane, level there
}

// Frames prepared in parallel reach the layer in any order: the layer and the views are those of
// the frames one after another.
TEST(FloorLayer, FramesObservedOutOfTurnGiveTheLayerAndViewsOfTheirTurns) {
  std::vector<std::vector<Eigen::Vector3d>> frames = {floorFrame(0.0), floorFrame(0.02, 1.0, 3.0), {},
                                                      floorFrame(0.01, 2.0, 4.0), floorFrame(0.03, 0.0, 4.0)};
  std::vector<Eigen::Vector3d> table;
  addSurface(&table, 0.5, 2.0, 0.0, 2.0, 0.72);
  frames.insert(frames.begin() + 2, table);
  const auto sensorOf = [](std::size_t k) { return Eigen::Vector3d(0.4 * k, 1.0, 1.2); };
  const auto heights = [](const FloorView& view) {
    std::vector<double> h;
    for (double x = -0.5; x < 5.0; x += 0.05) h.push_back(view.heightAt(x, 1.02));
    return h;
  };
  const auto cells = [](const FloorLayer& layer) {
    std::vector<std::tuple<int, int, float>> all;
    layer.forEachCell([&](std::uint16_t x, std::uint16_t y, float h) { all.emplace_back(x, y, h); });
    std::sort(all.begin(), all.end());
    return all;
  };
  FloorLayer in_turn(kResolution, {});
  std::vector<std::vector<double>> expected;
  for (std::size_t k = 0; k < frames.size(); ++k) expected.push_back(heights(in_turn.observe(sensorOf(k), frames[k], 10.0)));

  // Each frame after the one after it (1, 0, 3, 2, ...), the last number passed.
  FloorLayer swapped(kResolution, {});
  std::vector<std::uint64_t> numbers;
  for (std::size_t k = 0; k <= frames.size(); ++k) numbers.push_back(swapped.take());
  for (std::size_t k = 0; k < frames.size(); k += 2) {
    if (k + 1 < frames.size()) {
      EXPECT_EQ(heights(swapped.observe(numbers[k + 1], sensorOf(k + 1), frames[k + 1], 10.0)), expected[k + 1]) << k + 1;
    }
    EXPECT_EQ(heights(swapped.observe(numbers[k], sensorOf(k), frames[k], 10.0)), expected[k]) << k;
  }
  swapped.pass(numbers.back());
  swapped.pass(numbers.front());  // observed: nothing
  EXPECT_EQ(cells(swapped), cells(in_turn));
  EXPECT_EQ(swapped.status().frames_found, in_turn.status().frames_found);
  EXPECT_EQ(swapped.status().frames_without, in_turn.status().frames_without);
  // A frame after the passed one is not held up by it.
  swapped.observe(Eigen::Vector3d(0.0, 1.0, 1.2), {}, 10.0);
  EXPECT_EQ(swapped.status().frames_without, in_turn.status().frames_without + 1);
}

TEST(FloorLayer, ATableTopAboveAKnownFloorIsNotTheFloor) {
  FloorLayer layer(kResolution, {});
  layer.observe(Eigen::Vector3d(0.0, 1.0, 1.2), floorFrame(0.0), 10.0);
  std::vector<Eigen::Vector3d> table;
  addSurface(&table, 0.5, 2.0, 0.0, 2.0, 0.72);
  for (std::uint64_t k = 1; k < FloorLayer::kLag; ++k) layer.observe(Eigen::Vector3d(0.0, 1.0, 1.2), {}, 10.0);
  const FloorView view = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.2), table, 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  EXPECT_NEAR(view.heightAt(1.0, 1.0), 0.0, 0.01);
  // Seen by the frame just after the floor's, the table is not the floor either: it is measured
  // against the layer before the floor, but folded in after it.
  FloorLayer next(kResolution, {});
  next.observe(Eigen::Vector3d(0.0, 1.0, 1.2), floorFrame(0.0), 10.0);
  next.observe(Eigen::Vector3d(0.0, 1.0, 1.2), table, 10.0);
  EXPECT_EQ(next.status().source, FloorSource::kKept);
  EXPECT_EQ(next.status().frames_found, 1u);
  // A step of a few centimetres up (a ramp's next frame) is floor.
  layer.observe(Eigen::Vector3d(1.0, 1.0, 1.2), floorFrame(0.04, 1.0, 3.0), 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kFound);
}

// Where the floor under the sensor was seen, a level surface more than cloud_mark_min_z (max_step,
// 5 cm) above it is a step's top: a robot's camera at a wide step sees only that. Where it was only
// followed from a plane (a hand-held camera looking ahead), max_rise (8 cm) still holds.
TEST(FloorLayer, ALevelSurfaceAStepAboveASeenFloorIsNotTheFloor) {
  FloorLayer layer(kResolution, {});
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) layer.observe(Eigen::Vector3d(0.5, 1.0, 0.35), floorFrame(0.0), 10.0);
  std::vector<Eigen::Vector3d> top;
  addSurface(&top, 1.0, 3.0, 0.0, 2.0, 0.06);
  const FloorView view = layer.observe(Eigen::Vector3d(0.5, 1.0, 0.35), top, 10.0);
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  EXPECT_NEAR(view.heightAt(1.5, 1.0), 0.0, 0.01);
  // Over a cell whose floor nobody saw, the same surface is the floor (within max_rise).
  FloorLayer ahead(kResolution, {});
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) ahead.observe(Eigen::Vector3d(-2.0, 1.0, 1.2), floorFrame(0.0), 10.0);
  ahead.observe(Eigen::Vector3d(-2.0, 1.0, 1.2), top, 10.0);
  EXPECT_EQ(ahead.status().source, FloorSource::kFound);
}

// A hand-held camera at the foot of a ramp sees the platform fill its view and little of the floor
// under it: the platform's plane, a step above the floor seen, is the floor all the same where the
// frame shows the ramp climbing to it; with a step up instead of the ramp, it is not.
TEST(FloorLayer, APlatformTheFrameSeesARampClimbToIsTheFloor) {
  const Eigen::Vector3d sensor(0.5, 0.2, 1.0);
  const auto frameUpTo = [](bool ramp) {
    std::vector<Eigen::Vector3d> samples;
    addSurface(&samples, 0.9, 1.0, 0.0, 0.4, 0.0);  // a strip of the floor
    if (ramp) {
      // 0.10 m over 1.2 m (1 in 12), a strip of it in view.
      std::mt19937 rng(7);
      std::normal_distribution<double> gauss(0.0, 0.005);
      for (double x = 1.025; x < 2.2; x += kResolution) {
        for (double y = 0.025; y < 0.4; y += kResolution) samples.emplace_back(x, y, 0.10 * (x - 1.0) / 1.2 + gauss(rng));
      }
      addSurface(&samples, 2.2, 4.0, 0.0, 2.0, 0.10);
    } else {
      addSurface(&samples, 1.0, 1.05, 0.0, 0.4, 0.05);  // the step's edge, a mixed column halfway up
      addSurface(&samples, 1.05, 4.0, 0.0, 2.0, 0.10);
    }
    return samples;
  };
  for (const bool ramp : {true, false}) {
    FloorLayer layer(kResolution, {});
    for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) layer.observe(sensor, floorFrame(0.0, 0.0, 1.0), 10.0);
    const FloorView view = layer.observe(sensor, frameUpTo(ramp), 10.0);
    EXPECT_EQ(layer.status().source, ramp ? FloorSource::kFound : FloorSource::kKept) << "ramp " << ramp;
    EXPECT_NEAR(view.heightAt(3.0, 1.0), ramp ? 0.10 : 0.0, 0.01) << "ramp " << ramp;
    EXPECT_NEAR(view.heightAt(0.5, 0.5), 0.0, 0.01) << "ramp " << ramp;  // the floor seen stays
  }
  // A stray return 150 m off, within a long reach, spreads the frame over 9 M cells: it is not
  // searched (nor its grid allocated), and the table rule holds as without the search.
  FloorLayer layer(kResolution, {});
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) layer.observe(sensor, floorFrame(0.0, 0.0, 1.0), 200.0);
  std::vector<Eigen::Vector3d> stray = frameUpTo(true);
  stray.emplace_back(150.0, 150.0, 0.5);
  layer.observe(sensor, stray, 200.0);
  EXPECT_EQ(layer.status().source, FloorSource::kKept);
  // Beyond the reach, such a return is no part of the frame's cells: the ramp is found again.
  FloorLayer near(kResolution, {});
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) near.observe(sensor, floorFrame(0.0, 0.0, 1.0), 10.0);
  stray.emplace_back(-1630.0, -1630.0, 0.5);
  near.observe(sensor, stray, 10.0);
  EXPECT_EQ(near.status().source, FloorSource::kFound);
}

// A stray return far off (1.6 km, within the octree of 5 cm voxels) gives the layer no cell
// beyond the sensor's reach, and one within a long reach (900 m) no grid of the frame's box (a
// gigabyte of flags): the floor is found all the same, within the memory a frame needs.
TEST(FloorLayer, StrayReturnsFarOffCostNoGridOfTheirBox) {
  for (const auto& [reach, stray, cells] : {std::tuple<double, double, std::size_t>{10.0, 1630.0, 40u * 40u},
                                            std::tuple<double, double, std::size_t>{1000.0, 900.0, 40u * 40u + 2u}}) {
    std::vector<Eigen::Vector3d> samples = floorFrame(0.0);
    samples.emplace_back(-stray, -stray, 0.5);
    samples.emplace_back(stray, stray, 0.5);
    FloorLayer layer(kResolution, {});
    const long peak_before = peakResidentKb();
    const FloorView view = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), samples, reach);
    if (peak_before > 0) {
      EXPECT_LT(peakResidentKb() - peak_before, 256 * 1024) << "reach " << reach;
    }
    EXPECT_EQ(layer.status().source, FloorSource::kFound) << "reach " << reach;
    EXPECT_NEAR(view.heightAt(1.0, 1.0), 0.0, 0.01) << "reach " << reach;
    EXPECT_EQ(layer.status().cells, cells) << "reach " << reach;  // the floor's, and the returns' within reach
  }
}

// With the robot's ground point, the floor under it is the one it stands on: at a stairwell's edge
// the landing below does not replace it (without the point it does: the frame's lowest plane wins),
// and a platform it climbed is its floor although a step above the floor seen before.
TEST(FloorLayer, WithAGroundPointTheFloorUnderARobotIsTheOneItStandsOn) {
  std::vector<Eigen::Vector3d> edge = floorFrame(0.0, 0.0, 1.5);
  addSurface(&edge, 1.5, 4.0, 0.0, 2.0, -1.0);
  const Eigen::Vector3d sensor(0.5, 1.0, 0.35), ground(0.5, 1.0, 0.0);
  for (const bool grounded : {true, false}) {
    FloorLayer layer(kResolution, {});
    const std::optional<Eigen::Vector3d> point = grounded ? std::optional<Eigen::Vector3d>(ground) : std::nullopt;
    for (std::uint64_t k = 0; k < FloorLayer::kLag + 4; ++k) layer.observe(sensor, floorFrame(0.0), 10.0, point);
    FloorView view;
    for (int k = 0; k < 3; ++k) view = layer.observe(sensor, edge, 10.0, point);
    const FloorView later = layer.observe(sensor, floorFrame(0.0), 10.0, point);
    if (grounded) {
      EXPECT_EQ(layer.status().source, FloorSource::kFound);
      EXPECT_NEAR(view.heightAt(0.5, 1.0), 0.0, 0.01);
      EXPECT_NEAR(later.heightAt(0.5, 1.0), 0.0, 0.01);
      EXPECT_NEAR(layer.status().height, 0.0, 0.01);
    } else {
      EXPECT_NEAR(view.heightAt(0.5, 1.0), -1.0, 0.02);  // the limit the ground point removes
    }
  }
  // Up onto a 6 cm platform: its top is the floor under the robot once the robot stands on it.
  FloorLayer climbed(kResolution, {});
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) climbed.observe(sensor, floorFrame(0.0), 10.0, ground);
  std::vector<Eigen::Vector3d> top;
  addSurface(&top, 0.0, 3.0, 0.0, 2.0, 0.06);
  const Eigen::Vector3d on_top(0.5, 1.0, 0.06);
  for (std::uint64_t k = 0; k < FloorLayer::kLag + 1; ++k) {
    climbed.observe(sensor + Eigen::Vector3d(0.0, 0.0, 0.06), top, 10.0, on_top);
  }
  EXPECT_EQ(climbed.status().source, FloorSource::kFound);
  EXPECT_NEAR(climbed.status().height, 0.06, 0.01);
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

// A cell's slice band starts from the voxel layer nearest its floor, whatever the fallback's
// layer: on a floor rising 1.3 degrees, cells whose floor lies 0.3 of a voxel up keep layer 0 while
// the floor under the sensor (0.06 m) sets the fallback's layer to 1. (A band starting a layer
// higher would miss the top of an 8 cm step standing on those cells.)
TEST(FloorLayer, ACellsLevelIsTheLayerNearestItsFloor) {
  FloorLayer layer(kResolution, {});
  std::vector<Eigen::Vector3d> ramp;
  for (double x = 0.025; x < 2.0; x += kResolution) {
    for (double y = 0.025; y < 2.0; y += kResolution) ramp.emplace_back(x, y, 0.015 + 0.0225 * x);
  }
  layer.observe(Eigen::Vector3d(2.0, 1.0, 1.2), ramp, 10.0);
  const FloorLayer::LevelChanges changes = layer.takeLevelChanges();
  EXPECT_EQ(changes.fallback_level, 1);
  std::size_t checked = 0;
  for (const auto& [cell, level] : changes.cells) {
    const double x = (int(cell & 0xffff) - 32768 + 0.5) * kResolution;
    EXPECT_EQ(level, int(std::lround((0.015 + 0.0225 * x) / kResolution))) << "x " << x;
    checked += x < 0.3;
  }
  EXPECT_GT(checked, 100u);  // cells at layer 0 beside a fallback at layer 1
}

TEST(FloorLayer, AViewKeepsTheFloorAsOfItsFrame) {
  FloorLayer layer(kResolution, {});
  const FloorView before = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), floorFrame(0.0), 10.0);
  FloorOptions options;
  options.memory_frames = 1;
  layer.setOptions(options);
  layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), floorFrame(0.04), 10.0);  // the same cells, 4 cm up
  EXPECT_NEAR(before.heightAt(1.0, 1.0), 0.0, 0.01);
  FloorView after;
  for (std::uint64_t k = 0; k < FloorLayer::kLag; ++k) after = layer.observe(Eigen::Vector3d(0.0, 1.0, 1.0), {}, 10.0);
  EXPECT_NEAR(before.heightAt(1.0, 1.0), 0.0, 0.01);
  EXPECT_NEAR(after.heightAt(1.0, 1.0), 0.02, 0.01);  // the mean of the two frames
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

TEST(FloorLayer, LevelChangesAreTakenAsOfAFrameWhateverLaterFramesWereFoldedIn) {
  // A pipeline may fold frames 1 and 2 in before the map inserts frame 0: the map inserting
  // frame 0 takes frame 0's changes only, as it would have inserting frame after frame.
  FloorLayer layer(kResolution, {});
  layer.observe(0, Eigen::Vector3d(0.0, 1.0, 0.0), floorFrame(-1.5, 0.0, 1.0), 10.0);
  layer.observe(1, Eigen::Vector3d(0.0, 1.0, 0.0), floorFrame(-1.5, 1.0, 2.0), 10.0);
  layer.observe(2, Eigen::Vector3d(0.0, 1.0, 0.0), floorFrame(-0.5, 3.0, 4.0), 10.0);
  const FloorLayer::LevelChanges first = layer.takeLevelChanges(1);
  EXPECT_TRUE(first.fallback_changed);
  EXPECT_EQ(first.fallback_level, -30);
  EXPECT_EQ(first.cells.size(), 20u * 40u) << "frame 0's cells";
  const FloorLayer::LevelChanges second = layer.takeLevelChanges(2);
  EXPECT_FALSE(second.fallback_changed);
  EXPECT_EQ(second.fallback_level, -30);
  EXPECT_EQ(second.cells.size(), 20u * 40u) << "frame 1's cells";
  EXPECT_TRUE(layer.takeLevelChanges(2).cells.empty()) << "taken once";
  // Frame 2 found a floor a metre higher (a lower one is the floor; a higher one, beyond
  // max_rise, is not): whatever it changed comes with it, with the fallback as of frame 2.
  const FloorLayer::LevelChanges rest = layer.takeLevelChanges();
  EXPECT_EQ(rest.fallback_level, layer.fallbackLevel());
}

// The cells a caller gives (its end voxels' columns) stand for the samples' own: where they are
// the same, so are the layer and the view; where a given cell differs, the floor found is kept
// in the cell given.
TEST(FloorLayer, CellsGivenStandForTheSamplesOwn) {
  std::vector<Eigen::Vector3d> samples = floorFrame(-0.5);
  addSurface(&samples, 0.0, 1.0, 0.0, 0.5, 0.4);  // a table: another column's surface
  std::vector<std::uint32_t> cells;
  for (const Eigen::Vector3d& p : samples) {
    cells.push_back(std::uint32_t(floorKeyOf(p.x(), kResolution)) | std::uint32_t(floorKeyOf(p.y(), kResolution)) << 16);
  }
  FloorLayer computed(kResolution, {}), given(kResolution, {});
  const Eigen::Vector3d sensor(0.0, 1.0, 1.0);
  const FloorView a = computed.observe(sensor, samples, 10.0);
  const FloorView b = given.observe(0, sensor, samples, 10.0, &cells);
  EXPECT_EQ(computed.status().cells, given.status().cells);
  for (double x = -0.3; x < 2.3; x += 0.07) {
    for (double y = -0.3; y < 2.3; y += 0.07) {
      ASSERT_EQ(a.heightAt(x, y), b.heightAt(x, y)) << x << " " << y;
      ASSERT_EQ(b.heightAt(x, y), b.heightAtKeys(floorKeyOf(x, kResolution), floorKeyOf(y, kResolution), x, y));
    }
  }
  // Every sample put in one column beyond the samples: only that column is known.
  const int k = floorKeyOf(2.6, kResolution);
  std::vector<std::uint32_t> far(samples.size(), std::uint32_t(k) | std::uint32_t(k) << 16);
  FloorLayer moved(kResolution, {});
  moved.observe(0, sensor, samples, 10.0, &far);
  EXPECT_EQ(moved.status().cells, 1u);
  std::size_t seen = 0;
  moved.forEachCell([&](std::uint16_t kx, std::uint16_t ky, float h) {
    EXPECT_EQ(kx, k);
    EXPECT_EQ(ky, k);
    EXPECT_NEAR(h, -0.5, 0.02);
    ++seen;
  });
  EXPECT_EQ(seen, 1u);
}
