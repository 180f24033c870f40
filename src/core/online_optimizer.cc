#include "octo_slice_mapper/online_optimizer.h"

#include <chrono>
#include <cmath>
#include <cstring>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace octo_slice_mapper {
namespace {

constexpr int kPassNice = 10;

// Byte for byte: a scan holding a NaN reading (REP 117's "invalid", common on real lidars) never
// compares equal to itself with ==, and every pass then took the full first sweep.
bool sameScan(const StoredScan& a, const StoredScan& b) {
  return a.origin == b.origin && a.rotation.coeffs() == b.rotation.coeffs() && a.angle_min == b.angle_min &&
         a.angle_increment == b.angle_increment && a.range_min == b.range_min && a.range_max == b.range_max &&
         a.ranges.size() == b.ranges.size() &&
         std::memcmp(a.ranges.data(), b.ranges.data(), a.ranges.size() * sizeof(float)) == 0;
}

}  // namespace

GridImage warmStartFrom(const GridImage& last_result, const GridImage& incremental) {
  if (last_result.width <= 0 || incremental.width <= 0) return incremental;
  GridImage start = inFrameOf(last_result, incremental);
  if (start.resolution != incremental.resolution) return incremental;
  // `start` covers the incremental frame (grown where the last result reaches beyond it).
  const int di = static_cast<int>(std::lround((incremental.origin_x - start.origin_x) / start.resolution));
  const int dj = static_cast<int>(std::lround((incremental.origin_y - start.origin_y) / start.resolution));
  for (int j = 0; j < incremental.height; ++j) {
    for (int i = 0; i < incremental.width; ++i) {
      std::int8_t& cell = start.cells[std::size_t(j + dj) * start.width + (i + di)];
      if (cell == kUnknownCell) cell = incremental.at(i, j);
    }
  }
  return start;
}

OnlineOptimizer::OnlineOptimizer(const GlobalOptimizerOptions& options, double resolution)
    : options_(options), resolution_(resolution), worker_([this] { run(); }) {}

OnlineOptimizer::~OnlineOptimizer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  stop_pass_ = true;
  wake_.notify_all();
  worker_.join();
}

void OnlineOptimizer::submit(OnlineOptimizerInput input) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    waiting_ = std::move(input);
  }
  wake_.notify_all();
}

std::optional<OnlineOptimizerResult> OnlineOptimizer::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<OnlineOptimizerResult> out = std::move(ready_);
  ready_.reset();
  return out;
}

bool OnlineOptimizer::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return running_ || waiting_.has_value();
}

void OnlineOptimizer::forget() {
  std::lock_guard<std::mutex> lock(mutex_);
  last_ = GridImage();
  last_scan_count_ = 0;
  last_first_scan_.reset();
  last_last_scan_.reset();
  last_converged_ = false;
  ready_.reset();
  ++generation_;
}

void OnlineOptimizer::run() {
#ifdef __linux__
  // Background work: below the mapping threads' priority when both want a core (Linux's nice is
  // per thread; the pass's own worker threads inherit it). Not SCHED_IDLE: on a busy robot that
  // would starve the pass, and it did not lower the scans' p99 latency here either.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), kPassNice);
#endif
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || waiting_.has_value(); });
    if (stopping_) return;
    OnlineOptimizerInput input = std::move(*waiting_);
    waiting_.reset();
    running_ = true;
    const GridImage last = last_;
    const std::uint64_t generation = generation_;
    // The last input's scans still lead this one's: the store only appended to them.
    const bool appended = last_converged_ && last_scan_count_ > 0 && input.scans.size() >= last_scan_count_ &&
                          input.options_version == last_options_version_ &&
                          sameScan(input.scans.front(), *last_first_scan_) &&
                          sameScan(input.scans[last_scan_count_ - 1], *last_last_scan_);
    const std::size_t revisit_from = appended ? last_scan_count_ : 0;
    lock.unlock();

    const auto t0 = std::chrono::steady_clock::now();
    const GridImage start = warmStartFrom(last, input.incremental);
    OnlineOptimizerResult result;
    const GlobalOptimizerOptions& options = input.options ? *input.options : options_;
    const RevisitFrom revisit{revisit_from, &last};
    result.map = optimizeScans(input.scans, options, resolution_, &start, {}, revisit_from > 0 ? &revisit : nullptr,
                               &optimizer_, &stop_pass_);
    result.map.grid = inFrameOf(result.map.grid, input.incremental);
    result.shown = withObstacles(result.map.grid, input.incremental, input.beside);
    result.scans_revisited_from = revisit_from;
    result.version = input.version;
    result.newest_stamp = input.newest_stamp;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    lock.lock();
    running_ = false;
    if (stopping_) return;  // a pass stopped early is no result
    // After a forget() during the pass, its result belongs to the map before: dropped.
    if (generation == generation_) {
      // The next pass starts from this one's state, not its exported map: a cell it freed behind a
      // wall (unknown in the map) would otherwise come back occupied from the incremental map,
      // be looked at and freed again in every pass, and cost each pass sweeps over its beams.
      last_ = result.map.state;
      last_scan_count_ = input.scans.size();
      if (!input.scans.empty()) last_first_scan_ = input.scans.front(), last_last_scan_ = input.scans.back();
      last_converged_ = result.map.report.converged;
      last_options_version_ = input.options_version;
      ready_ = std::move(result);
    }
  }
}

}  // namespace octo_slice_mapper
