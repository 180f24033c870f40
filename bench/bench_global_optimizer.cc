// bench_global_optimizer: the global pass (Task 2) on the shared CARMEN datasets at 0.05 m.
//
//   bench_global_optimizer [--data DIR] [--repeats N] [--only intel|fr079]
//
// For each dataset, in one process: all scans into a Mapper, then the global pass from all-free
// (the lab's start) and warm from the incremental map, each `repeats` times: median seconds
// (index + sweeps), sweeps, flips, and the process's peak resident memory during the pass
// (VmHWM, reset before each run through /proc/self/clear_refs; it includes the loaded log and
// the octree). Then the background pass as the node runs it, with one thread and every core.
// Map quality on held-out scans: bench_map_quality.
// Targets: Intel <= 10 s, Freiburg 079 <= 60 s, peak memory <= 1 GB.
#include <algorithm>
#include <chrono>
#include <optional>
#include <thread>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/carmen_log.h"
#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/online_optimizer.h"

namespace osm = octo_slice_mapper;

using osm::bench::median;

namespace {

// Resets the kernel's peak-RSS mark of this process (Linux >= 4.0); false where not allowed.
bool resetPeakRss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  return static_cast<bool>(clear.flush());
}

double peakRssMb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.compare(0, 6, "VmHWM:") == 0) return std::atof(line.c_str() + 6) / 1024.0;
  }
  return -1.0;
}

struct Dataset {
  std::string name, path;
  double target_seconds;
};

struct Timing {
  double seconds = 0.0, peak_mb = 0.0;
  int sweeps = 0;
  std::size_t flips = 0, cells = 0, beams = 0;
  bool converged = false;
};

Timing timeGlobalPass(const osm::Mapper& mapper, bool warm_start, int repeats) {
  std::vector<double> seconds;
  Timing t;
  for (int r = 0; r < repeats; ++r) {
    resetPeakRss();
    const osm::OptimizedMap result = mapper.optimize(warm_start);
    t.peak_mb = std::max(t.peak_mb, peakRssMb());
    seconds.push_back(result.report.build_seconds + result.report.optimize_seconds);
    t.sweeps = result.report.sweeps;
    t.converged = result.report.converged;
    t.cells = result.report.cells;
    t.beams = result.report.beams;
    t.flips = 0;
    for (std::size_t f : result.report.flips_per_sweep) t.flips += f;
  }
  t.seconds = median(seconds);
  return t;
}

// The background pass as the node runs it (OnlineOptimizer): a converged pass over all scans but
// the last `kNewScans`, then the timed one over all, which revisits only what the new scans
// reach; with one worker thread and with every core, paired in this process.
void timeOnlinePass(const std::vector<osm::LogScan>& log, const osm::Mapper& all, int repeats) {
  constexpr std::size_t kNewScans = 15;  // about 3 s of Freiburg 079 at its 4.4 scans/s
  if (log.size() <= kNewScans) return;
  osm::Mapper earlier;
  for (std::size_t i = 0; i + kNewScans < log.size(); ++i) earlier.insert(log[i].scan);
  const osm::MapSnapshot before = earlier.optimizationInput(), now = all.optimizationInput();
  std::printf("  %-28s %8s %8s %8s %9s %9s\n", "online pass, last 15 scans new", "seconds", "index s", "sweeps s",
              "revisits", "extended");
  std::vector<double> serial;
  for (int threads : {1, 0}) {
    osm::GlobalOptimizerOptions options = all.options().optimizer;
    options.threads = threads;
    std::vector<double> seconds, index, sweeps;
    bool revisited = true, extended = true;
    for (int r = 0; r < repeats; ++r) {
      osm::OnlineOptimizer pass(options, all.options().resolution);
      const auto wait = [&pass] {
        std::optional<osm::OnlineOptimizerResult> result;
        while (!(result = pass.take())) std::this_thread::sleep_for(std::chrono::milliseconds(2));
        return *result;
      };
      pass.submit({before.scans, before.slice, 1, 0.0, std::nullopt, 0, {}});
      wait();
      pass.submit({now.scans, now.slice, 2, 0.0, std::nullopt, 0, {}});
      const osm::OnlineOptimizerResult result = wait();
      seconds.push_back(result.seconds);
      index.push_back(result.map.report.build_seconds);
      sweeps.push_back(result.map.report.optimize_seconds);
      revisited = revisited && result.scans_revisited_from > 0;
      extended = extended && result.map.report.index_extended;
    }
    std::printf("  %-28s %8.2f %8.2f %8.2f %9s %9s\n", threads == 1 ? "one thread" : "every core", median(seconds),
                median(index), median(sweeps), revisited ? "yes" : "NO", extended ? "yes" : "no");
    if (threads == 1) serial = seconds;
    else std::printf("  every core vs one thread: %.2fx faster (medians)\n", median(serial) / median(seconds));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* env = std::getenv("OSM_DATA_DIR");
  std::string data = env && *env ? env : "../shared/data", only;
  int repeats = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--data" && i + 1 < argc) data = argv[++i];
    else if (arg == "--repeats" && i + 1 < argc) repeats = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--only" && i + 1 < argc) only = argv[++i];
    else {
      std::fprintf(stderr, "usage: bench_global_optimizer [--data DIR] [--repeats N] [--only NAME]\n");
      return 2;
    }
  }
  const bool rss_resettable = resetPeakRss();
  const std::vector<Dataset> datasets = {
      {"intel", data + "/intel_corrected/intel-corrected.log.gz", 10.0},
      {"fr079", data + "/fr079_corrected/freiburg-079-corrected.log.gz", 60.0}};
  bool all_met = true;
  for (const Dataset& d : datasets) {
    if (!only.empty() && only != d.name) continue;
    std::string error;
    const std::vector<osm::LogScan> log = osm::readCarmenLog(d.path, {}, &error);
    if (log.empty()) {
      std::fprintf(stderr, "bench_global_optimizer: %s\n", error.empty() ? "no scans" : error.c_str());
      return 1;
    }
    osm::Mapper all;
    for (const osm::LogScan& record : log) all.insert(record.scan);
    std::printf("== %s: %zu scans x %zu beams, 0.05 m, %d repeats (median)\n", d.name.c_str(), log.size(),
                log.front().scan.ranges.size(), repeats);
    std::printf("  %-28s %8s %7s %8s %9s %9s %10s\n", "global pass, all scans", "seconds", "sweeps", "flips",
                "converged", "peak MB", "target");
    Timing t;
    for (bool warm : {false, true}) {
      t = timeGlobalPass(all, warm, repeats);
      const bool met = t.seconds <= d.target_seconds && t.peak_mb <= 1024.0;
      all_met = all_met && met;
      std::printf("  %-28s %8.2f %7d %8zu %9s %9.0f %5.0f s %s\n", warm ? "from incremental (warm)" : "from empty (lab)",
                  t.seconds, t.sweeps, t.flips, t.converged ? "yes" : "no", t.peak_mb, d.target_seconds,
                  met ? "met" : "MISSED");
    }
    std::printf("  (%zu observed cells, %zu beams; scan store %.1f MB)\n", t.cells, t.beams,
                all.scanStore().memoryBytes() / 1e6);
    timeOnlinePass(log, all, repeats);

  }
  if (!rss_resettable) std::printf("note: /proc/self/clear_refs not writable: peak MB is the process's peak so far\n");
  std::printf("targets %s\n", all_met ? "met" : "MISSED");
  return 0;
}
