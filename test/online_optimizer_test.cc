// The global pass in the background: a result equal to the same pass run in the foreground, the
// next pass starting from the last result, newer inputs replacing waiting ones, forget().
#include "octo_slice_mapper/online_optimizer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"

using namespace octo_slice_mapper;

namespace {

OnlineOptimizerResult waitFor(OnlineOptimizer* online) {
  for (int i = 0; i < 6000; ++i) {
    if (auto r = online->take()) return std::move(*r);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ADD_FAILURE() << "no result within 60 s";
  return {};
}

struct Session {
  Mapper mapper;
  std::vector<Scan> scans;
  Session() : scans(sim::SimulatedSession(sim::FloorPlan::doorCorridor(), sim::SessionSpec::corridorPass()).allScans()) {}
  explicit Session(std::vector<Scan> given) : scans(std::move(given)) {}
  OnlineOptimizerInput insertUpTo(std::size_t n, std::uint64_t version) {
    for (std::size_t k = mapper.stats().scans_inserted; k < n; ++k) EXPECT_TRUE(mapper.insert(scans[k]).ok());
    MapSnapshot input = mapper.optimizationInput();
    return {std::move(input.scans), std::move(input.slice), version, scans[n - 1].stamp, std::nullopt, 0, {}};
  }
};

}  // namespace

TEST(OnlineOptimizer, GivesTheForegroundPassesResult) {
  Session s;
  OnlineOptimizer online(s.mapper.options().optimizer, s.mapper.options().resolution);
  OnlineOptimizerInput input = s.insertUpTo(s.scans.size(), 7);
  const GridImage incremental = input.incremental;
  const OptimizedMap foreground = s.mapper.optimize(/*warm_start=*/true);
  online.submit(std::move(input));
  const OnlineOptimizerResult r = waitFor(&online);
  EXPECT_EQ(r.version, 7u);
  EXPECT_DOUBLE_EQ(r.newest_stamp, s.scans.back().stamp);
  EXPECT_GT(r.seconds, 0.0);
  const GridImage expected = inFrameOf(foreground.grid, incremental);
  EXPECT_EQ(r.map.grid.width, expected.width);
  EXPECT_EQ(r.map.grid.cells, expected.cells);
  EXPECT_EQ(r.map.report.final_log_likelihood, foreground.report.final_log_likelihood);
  EXPECT_FALSE(online.busy());
}

TEST(OnlineOptimizer, TheNextPassStartsFromTheLastResult) {
  Session s;
  OnlineOptimizer online(s.mapper.options().optimizer, s.mapper.options().resolution);
  online.submit(s.insertUpTo(s.scans.size() / 2, 1));
  const OnlineOptimizerResult first = waitFor(&online);
  ASSERT_TRUE(first.map.report.converged);
  EXPECT_EQ(first.scans_revisited_from, 0u) << "the first pass looks at every cell";
  const std::size_t first_scans = s.mapper.scanStore().scans().size();
  online.submit(s.insertUpTo(s.scans.size(), 2));
  const OnlineOptimizerResult second = waitFor(&online);
  EXPECT_EQ(second.version, 2u);
  EXPECT_EQ(second.scans_revisited_from, first_scans) << "only the new scans' cells in the first sweep";
  // The same pass started from the first pass's state (where it knows a cell), with a full first
  // sweep, gives the same map and the same log-likelihood.
  const MapSnapshot all = s.mapper.optimizationInput();
  const GridImage start = warmStartFrom(first.map.state, all.slice);
  const OptimizedMap direct = optimizeScans(all.scans, s.mapper.options().optimizer, 0.05, &start);
  EXPECT_EQ(second.map.grid.cells, inFrameOf(direct.grid, all.slice).cells);
  EXPECT_EQ(second.map.report.final_log_likelihood, direct.report.final_log_likelihood);
  // ... which is not the pass started from the incremental map alone: the start carried over.
  const OptimizedMap from_incremental = optimizeScans(all.scans, s.mapper.options().optimizer, 0.05, &all.slice);
  EXPECT_NE(second.map.report.initial_log_likelihood, from_incremental.report.initial_log_likelihood);
}

// When the scans kept since the last pass stay within the extent it indexed (the office tour's
// last stretch drives back down the corridor), the pass extends the last index instead of
// building one: the same map and log-likelihood as the pass run in the foreground from the same
// start. (The office's lidar reports NaN now and then: the pass must still see that the store
// only appended; it once compared scans with ==, and NaN != NaN.)
TEST(OnlineOptimizer, AnExtendedIndexGivesTheForegroundPassesMap) {
  std::vector<Scan> tour =
      sim::SimulatedSession(sim::FloorPlan::office(), sim::SessionSpec::officeTour()).allScans();
  Session s(std::move(tour));
  OnlineOptimizer online(s.mapper.options().optimizer, s.mapper.options().resolution);
  const std::size_t n = s.scans.size();
  online.submit(s.insertUpTo(n - 20, 1));
  const OnlineOptimizerResult first = waitFor(&online);
  ASSERT_TRUE(first.map.report.converged);
  EXPECT_FALSE(first.map.report.index_extended) << "nothing to extend yet";
  online.submit(s.insertUpTo(n, 2));
  const OnlineOptimizerResult second = waitFor(&online);
  ASSERT_GT(second.scans_revisited_from, 0u);
  EXPECT_TRUE(second.map.report.index_extended) << "the last 20 scans stay within the tour's extent";
  const MapSnapshot all = s.mapper.optimizationInput();
  const GridImage start = warmStartFrom(first.map.state, all.slice);
  const OptimizedMap direct = optimizeScans(all.scans, s.mapper.options().optimizer, 0.05, &start);
  EXPECT_EQ(second.map.grid.cells, inFrameOf(direct.grid, all.slice).cells);
  EXPECT_EQ(second.map.report.final_log_likelihood, direct.report.final_log_likelihood);
}

TEST(OnlineOptimizer, WarmStartTakesTheLastResultAndFillsInFromTheSlice) {
  GridImage incremental;
  incremental.width = 3, incremental.height = 1, incremental.resolution = 0.05;
  incremental.cells = {90, 10, 80};
  GridImage last = incremental;
  last.width = 2;
  last.cells = {0, -1};
  const GridImage start = warmStartFrom(last, incremental);
  EXPECT_EQ(start.cells, (std::vector<std::int8_t>{0, 10, 80}));
  EXPECT_EQ(warmStartFrom(GridImage(), incremental).cells, incremental.cells);
}

TEST(OnlineOptimizer, ANewerInputReplacesAWaitingOneAndForgetDropsTheLastResult) {
  Session s;
  OnlineOptimizer online(s.mapper.options().optimizer, s.mapper.options().resolution);
  online.submit(s.insertUpTo(s.scans.size() / 3, 1));
  online.submit(s.insertUpTo(2 * s.scans.size() / 3, 2));
  online.submit(s.insertUpTo(s.scans.size(), 3));
  std::uint64_t newest = 0;
  int results = 0;
  while (online.busy() || newest < 3) {
    if (auto r = online.take()) {
      EXPECT_GT(r->version, newest) << "results come in submission order";
      newest = r->version;
      ++results;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(newest, 3u);
  EXPECT_LE(results, 3);
  online.forget();
  EXPECT_FALSE(online.take().has_value());
}

// When the kept scans are not the last input's with more appended (the store thinned or was
// replaced), the next pass looks at every cell again.
TEST(OnlineOptimizer, ScansThatChangedBeforeTheEndGetAFullFirstSweep) {
  Session s;
  OnlineOptimizer online(s.mapper.options().optimizer, s.mapper.options().resolution);
  OnlineOptimizerInput input = s.insertUpTo(s.scans.size(), 1);
  OnlineOptimizerInput thinned = input;
  thinned.version = 2;
  for (std::size_t k = 0; k + 1 < thinned.scans.size(); k += 2) thinned.scans[k].ranges[0] += 0.5f;  // not the same scans
  online.submit(std::move(input));
  ASSERT_EQ(waitFor(&online).version, 1u);
  online.submit(std::move(thinned));
  const OnlineOptimizerResult r = waitFor(&online);
  EXPECT_EQ(r.version, 2u);
  EXPECT_EQ(r.scans_revisited_from, 0u);
}
