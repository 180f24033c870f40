#include "octo_slice_mapper/global_optimizer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <limits>
#include <random>

#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

using namespace octo_slice_mapper;

namespace {

std::vector<StoredScan> storeAll(const std::vector<Scan>& scans) {
  ScanStore store;
  for (const Scan& s : scans) store.add(s);
  return store.scans();
}

int valueAt(const GridImage& g, double x, double y) {
  const int i = static_cast<int>(std::floor((x - g.origin_x) / g.resolution));
  const int j = static_cast<int>(std::floor((y - g.origin_y) / g.resolution));
  if (i < 0 || j < 0 || i >= g.width || j >= g.height) return -1;
  return g.at(i, j);
}

}  // namespace

TEST(GlobalOptimizer, IncrementalDeltaEqualsFullRecomputation) {
  // A few scans of the corridor, random binary maps over the observed cells.
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  std::vector<Scan> scans = session.allScans();
  scans.resize(40);
  GlobalOptimizer optimizer(GlobalOptimizerOptions{}, 0.1);
  optimizer.build(storeAll(scans));
  std::vector<std::size_t> observed;
  for (std::size_t c = 0; c < optimizer.cellCount(); ++c) {
    if (optimizer.observed(c)) observed.push_back(c);
  }
  ASSERT_GT(observed.size(), 200u);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    std::bernoulli_distribution occupied(0.05 + 0.1 * trial);
    for (std::size_t c : observed) optimizer.setOccupied(c, occupied(rng));
    optimizer.resetBeams();
    ASSERT_NEAR(optimizer.logLikelihood(), optimizer.recomputeLogLikelihood(), 1e-6);
    std::uniform_int_distribution<std::size_t> pick(0, observed.size() - 1);
    for (int k = 0; k < 40; ++k) {
      const std::size_t c = observed[pick(rng)];
      const double before = optimizer.recomputeLogLikelihood();
      const double predicted = optimizer.flipDelta(c);
      optimizer.flip(c);
      const double actual = optimizer.recomputeLogLikelihood() - before;
      ASSERT_NEAR(predicted, actual, 1e-6 * std::max(1.0, std::abs(actual))) << "trial " << trial << " cell " << c;
      ASSERT_NEAR(optimizer.logLikelihood(), optimizer.recomputeLogLikelihood(), 1e-5);
    }
  }
}

TEST(GlobalOptimizer, SweepsNeverLowerTheLikelihoodAndEndInALocalOptimum) {
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  GlobalOptimizer optimizer(GlobalOptimizerOptions{}, 0.05);
  optimizer.build(storeAll(session.allScans()));
  const OptimizeReport report = optimizer.optimize();
  ASSERT_TRUE(report.converged);
  double previous = report.initial_log_likelihood;
  for (double ll : report.log_likelihood_per_sweep) {
    EXPECT_GE(ll, previous);
    previous = ll;
  }
  EXPECT_GT(report.final_log_likelihood, report.initial_log_likelihood);
  EXPECT_EQ(report.flips_per_sweep.back(), 0u);
  EXPECT_NEAR(optimizer.logLikelihood(), optimizer.recomputeLogLikelihood(), 1e-6 * std::abs(optimizer.logLikelihood()));
  for (std::size_t c = 0; c < optimizer.cellCount(); ++c) {
    if (optimizer.observed(c)) {
      ASSERT_LE(optimizer.flipDelta(c), 1e-9) << "cell " << c << " would still improve";
    }
  }
}

// A stop asked for ends optimize() before its next sweep (the background pass at shutdown): none
// with the flag set from the start, the map and likelihood as built; and a later pass over the
// same index, with the flag cleared, converges as usual.
TEST(GlobalOptimizer, AStopEndsThePassBeforeItsNextSweep) {
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  GlobalOptimizer optimizer(GlobalOptimizerOptions{}, 0.05);
  optimizer.build(storeAll(session.allScans()));
  std::atomic<bool> stop{true};
  optimizer.stopWhen(&stop);
  const double before = optimizer.logLikelihood();
  const OptimizeReport stopped = optimizer.optimize();
  EXPECT_TRUE(stopped.stopped);
  EXPECT_FALSE(stopped.converged);
  EXPECT_EQ(stopped.sweeps, 0);
  EXPECT_EQ(optimizer.logLikelihood(), before);
  stop = false;
  const OptimizeReport report = optimizer.optimize();
  EXPECT_FALSE(report.stopped);
  EXPECT_TRUE(report.converged);
  EXPECT_GT(report.sweeps, 1);
  EXPECT_GT(optimizer.logLikelihood(), before);
}

TEST(GlobalOptimizer, AnyNumberOfThreadsGivesTheSameMapAndLikelihood) {
  // Indexing and judging cells in chunks on several threads must give the serial pass's result
  // bit for bit (same index order, same sums), from both starts.
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  const std::vector<StoredScan> scans = storeAll(session.allScans());
  for (bool warm : {false, true}) {
    GridImage reference;
    double reference_ll = 0.0;
    std::vector<std::size_t> reference_flips;
    for (int threads : {1, 2, 3}) {
      GlobalOptimizerOptions options;
      options.threads = threads;
      GlobalOptimizer optimizer(options, 0.05);
      optimizer.build(scans);
      ASSERT_GT(optimizer.beamCount(), 3u * 1024u) << "too few beams to be split among threads";
      if (warm) {
        GlobalOptimizer first(GlobalOptimizerOptions{}, 0.05);
        first.build(scans);
        first.optimize();
        GridImage start = first.result();
        for (std::size_t c = 0; c < start.cells.size(); c += 7) start.cells[c] = 100;  // a start unlike the optimum
        optimizer.startFrom(start);
      }
      const OptimizeReport report = optimizer.optimize();
      if (threads == 1) {
        reference = optimizer.result();
        reference_ll = report.final_log_likelihood;
        reference_flips = report.flips_per_sweep;
        continue;
      }
      EXPECT_EQ(report.final_log_likelihood, reference_ll) << threads << " threads, warm " << warm;
      EXPECT_EQ(report.flips_per_sweep, reference_flips) << threads << " threads, warm " << warm;
      EXPECT_EQ(optimizer.result().cells, reference.cells) << threads << " threads, warm " << warm;
    }
  }
}

// The background pass extends its last index by the scans kept since instead of building it anew:
// the same index, and so the same result, as a build of all the scans; refused (nothing changed)
// when the new beams reach beyond the traced extent, which would lay the grid out otherwise.
TEST(GlobalOptimizer, ExtendingTheIndexGivesWhatABuildOfAllGives) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  std::vector<Scan> all = session.allScans();
  all.resize(400);
  const std::vector<StoredScan> scans = storeAll(all);
  ASSERT_GT(scans.size(), 300u);
  GlobalOptimizer whole(GlobalOptimizerOptions{}, 0.05), grown(GlobalOptimizerOptions{}, 0.05);
  whole.build(scans);
  // The robot drives on: the first scans' extent grows. Find a split whose later scans stay in it.
  std::size_t split = 0;
  for (std::size_t first = scans.size() - 5; first > scans.size() / 2; first -= 5) {
    GlobalOptimizer probe(GlobalOptimizerOptions{}, 0.05);
    probe.build(std::vector<StoredScan>(scans.begin(), scans.begin() + first));
    if (probe.extend(scans, first)) {
      split = first;
      break;
    }
  }
  ASSERT_GT(split, 0u) << "no split whose new scans stay within the earlier ones' extent";
  grown.build(std::vector<StoredScan>(scans.begin(), scans.begin() + split));
  ASSERT_TRUE(grown.extend(scans, split));
  grown.startEmpty();  // the new beams' records are set by a start
  ASSERT_EQ(grown.cellCount(), whole.cellCount());
  ASSERT_EQ(grown.beamCount(), whole.beamCount());
  for (std::size_t c = 0; c < whole.cellCount(); ++c) ASSERT_EQ(grown.observed(c), whole.observed(c)) << c;
  const OptimizeReport a = whole.optimize(), b = grown.optimize();
  EXPECT_EQ(a.ray_cells, b.ray_cells);
  EXPECT_EQ(a.flips_per_sweep, b.flips_per_sweep);
  EXPECT_EQ(a.final_log_likelihood, b.final_log_likelihood);
  EXPECT_EQ(whole.result().cells, grown.result().cells);
  // The first scans alone do not hold the later ones: refused, and the index is left as it was.
  GlobalOptimizer early(GlobalOptimizerOptions{}, 0.05);
  const std::vector<StoredScan> first_few(scans.begin(), scans.begin() + 20);
  early.build(first_few);
  const std::size_t beams = early.beamCount();
  EXPECT_FALSE(early.extend(scans, 20));
  EXPECT_EQ(early.beamCount(), beams);
  EXPECT_EQ(early.scanCount(), 20u);
  EXPECT_FALSE(early.extend(scans, 19)) << "not the scans it was built from";
}

TEST(GlobalOptimizer, OpensTheDoorSonarConesPass) {
  // Sonar-like beams (20 deg cones that echo from their nearest obstacle) pass an open door. An
  // inverse model that marks the whole cross-section at the echo's range occupied spreads the
  // echoes from the wall beside the door over the doorway (Probabilistic Robotics sec. 9.4, the
  // lab's Figure 4). This one shares one echo's evidence across the cone (each voxel its width's
  // share) and sums the beams of a scan, so the beams that pass the doorway keep most of it open;
  // the forward model explains every echo by the wall inside the cone and opens all of it.
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  const double cone = session.spec().lidar.beam_width;
  MapperOptions options;
  options.insert.model.beam_opening_angle = cone;
  options.insert.model.sigma_base = 0.1;  // sonar range noise
  options.insert.model.sigma_per_meter = 0.02;
  Mapper mapper(options);
  const std::vector<Scan> scans = session.allScans();
  for (const Scan& s : scans) ASSERT_TRUE(mapper.insert(s).ok());
  const GridImage incremental = gridImageOf(mapper.slice());

  GlobalOptimizerOptions optimizer_options;
  optimizer_options.beam_opening_angle = cone;
  optimizer_options.model.sigma_base = 0.1;
  GlobalOptimizer optimizer(optimizer_options, options.resolution);
  optimizer.build(storeAll(scans));
  const OptimizeReport report = optimizer.optimize();
  ASSERT_TRUE(report.converged);
  const GridImage optimized = optimizer.result();

  const double wall_y = sim::kDoorCorridorWidth - 0.03;  // the corridor-side face of the north wall
  int incremental_free = 0, optimized_free = 0, cells = 0;
  for (double x = 4.525; x < 5.4; x += 0.05, ++cells) {
    const int inc = valueAt(incremental, x, wall_y), opt = valueAt(optimized, x, wall_y);
    std::printf("[ doorway x=%.3f ] incremental %3d optimized %3d\n", x, inc, opt);
    if (inc >= 0 && inc < 20) ++incremental_free;
    if (opt == 0) ++optimized_free;
  }
  std::printf("[ door ] %d sweeps, flips %zu in the first, log-likelihood %.1f -> %.1f\n", report.sweeps,
              report.flips_per_sweep.front(), report.initial_log_likelihood, report.final_log_likelihood);
  EXPECT_GE(incremental_free, cells / 2) << "sharing an echo across the cone should leave most of the doorway open";
  EXPECT_GE(optimized_free, cells - 1) << "the optimized map must open the door";
  // The walls beside the door stay walls.
  // (The face lies on a cell boundary: the first of two cell rows that is occupied is the wall.)
  for (double x : {3.5, 4.0, 4.3, 5.6, 6.0, 6.5}) {
    EXPECT_TRUE(valueAt(optimized, x, wall_y - 0.05) == 100 || valueAt(optimized, x, wall_y) == 100) << "wall at x=" << x;
  }
}

TEST(GlobalOptimizer, SimulatedSessionIsNotWorseThanTheIncrementalMap) {
  const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
  Mapper mapper;
  ScanStore store;
  for (const Scan& s : session.allScans()) {
    ASSERT_TRUE(mapper.insert(s).ok());
    store.add(s);
  }
  const GridImage truth = session.plan().groundTruth(0.05);
  const GridImage incremental = gridImageOf(mapper.slice());
  GlobalOptimizer optimizer(GlobalOptimizerOptions{}, 0.05);
  optimizer.build(store.scans());
  const OptimizeReport cold = optimizer.optimize();
  const OccupancyScore inc = scoreOccupancy(incremental, truth, 1);
  const OccupancyScore opt = scoreOccupancy(optimizer.result(), truth, 1);
  std::printf("[ simulated session ] incremental precision %.4f recall %.4f | optimized (from empty, %d sweeps, "
              "%.2f s) precision %.4f recall %.4f | store %.1f MB\n",
              inc.precision, inc.recall, cold.sweeps, cold.optimize_seconds, opt.precision, opt.recall,
              store.memoryBytes() / 1e6);
  EXPECT_TRUE(cold.converged);
  EXPECT_GE(opt.precision, inc.precision);
  EXPECT_GE(opt.recall, inc.recall - 0.005) << "recall may not drop noticeably";

  optimizer.startFrom(incremental);
  const OptimizeReport warm = optimizer.optimize();
  const OccupancyScore opt_warm = scoreOccupancy(optimizer.result(), truth, 1);
  std::printf("[ simulated session ] optimized (warm start, %d sweeps) precision %.4f recall %.4f\n", warm.sweeps,
              opt_warm.precision, opt_warm.recall);
  EXPECT_TRUE(warm.converged);
}

// The global pass reads readings by the insertion's rules, not the default ones whatever the
// insertion was told: with REP 117 on, +inf beams clear as no-returns in both.
TEST(GlobalOptimizer, ReadsInfinityAsTheInsertionDoes) {
  Scan scan;
  scan.sensor_pose.translation() = Eigen::Vector3d(0, 0, 0.26);
  scan.angle_min = -0.5f;
  scan.angle_increment = 0.01f;
  scan.range_min = 0.02f;
  scan.range_max = 5.6f;
  scan.ranges.assign(101, std::numeric_limits<float>::infinity());
  scan.ranges[50] = 2.0f;
  for (bool rep117 : {true, false}) {
    MapperOptions options;
    options.insert.readings.inf_is_no_return = rep117;
    options.insert.model.no_return_clear_distance = 3.0;
    Mapper mapper(options);
    ASSERT_TRUE(mapper.insert(scan).ok());
    EXPECT_EQ(mapper.stats().readings[ReadingKind::kNoReturn], rep117 ? 100u : 0u);
    const OptimizedMap optimized = mapper.optimize(/*warm_start=*/true);
    EXPECT_EQ(optimized.report.beams, rep117 ? 101u : 1u) << "REP 117 " << rep117;
  }
}

// A warm start brings in occupied cells no beam ever meets first (the incremental map's cells
// behind a wall's face). They explain nothing, so a tie would keep them; the pass frees them at
// the end, without changing the likelihood or leaving a cell that could still gain.
TEST(GlobalOptimizer, AWarmStartsCellsBehindAWallThatExplainNoBeamAreFreed) {
  const sim::SimulatedSession session(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass());
  GlobalOptimizer optimizer(GlobalOptimizerOptions{}, 0.05);
  optimizer.build(storeAll(session.allScans()));
  optimizer.optimize();
  GridImage start = optimizer.result();
  // Every occupied cell thickened by two cells in each direction: the cells added behind the
  // faces are within some beam's traced length (observed) but behind its first obstacle.
  GridImage thick = start;
  for (int j = 0; j < start.height; ++j) {
    for (int i = 0; i < start.width; ++i) {
      if (start.at(i, j) != 100) continue;
      for (int dj = -2; dj <= 2; ++dj) {
        for (int di = -2; di <= 2; ++di) {
          const int a = i + di, b = j + dj;
          if (a >= 0 && b >= 0 && a < start.width && b < start.height) thick.cells[std::size_t(b) * start.width + a] = 100;
        }
      }
    }
  }
  optimizer.startFrom(thick);
  const OptimizeReport report = optimizer.optimize();
  ASSERT_TRUE(report.converged);
  EXPECT_GT(report.released, 100u);
  EXPECT_NEAR(optimizer.logLikelihood(), optimizer.recomputeLogLikelihood(), 1e-6 * std::abs(optimizer.logLikelihood()));
  std::size_t unsupported = 0, occupied = 0;
  for (std::size_t c = 0; c < optimizer.cellCount(); ++c) {
    if (!optimizer.observed(c)) continue;
    ASSERT_LE(optimizer.flipDelta(c), 1e-9) << "cell " << c << " would still improve";
    if (!optimizer.occupied(c)) continue;
    ++occupied;
    // Freeing a cell that is some beam's first obstacle changes that beam's likelihood; freeing
    // one that explains no beam changes nothing.
    unsupported += optimizer.flipDelta(c) == 0.0;
  }
  EXPECT_GT(occupied, 100u);
  // Kept only where the grid walk and the distances to cell centres disagree (see
  // releaseUnsupported): a few cells at grazing angles.
  EXPECT_LT(unsupported, occupied / 100) << "occupied cells that explain no beam survived";
  // What is left of the thick walls: each occupied cell is some beam's first obstacle, so none
  // lies farther behind a face than the thickened start put it.
  std::size_t thick_occupied = 0;
  for (std::int8_t v : thick.cells) thick_occupied += v == 100;
  EXPECT_LT(occupied, thick_occupied / 2);
}
