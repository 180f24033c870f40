#include "octo_slice_mapper/online_optimizer.h"

#include <chrono>

namespace octo_slice_mapper {

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
  ready_.reset();
  ++generation_;
}

std::size_t OnlineOptimizer::memoryBytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::size_t bytes = last_.cells.capacity();
  if (waiting_) {
    for (const StoredScan& s : waiting_->scans) bytes += s.bytes();
    bytes += waiting_->incremental.cells.capacity();
  }
  return bytes;
}

void OnlineOptimizer::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || waiting_.has_value(); });
    if (stopping_) return;
    OnlineOptimizerInput input = std::move(*waiting_);
    waiting_.reset();
    running_ = true;
    const GridImage last = last_;
    const std::uint64_t generation = generation_;
    lock.unlock();

    const auto t0 = std::chrono::steady_clock::now();
    const GridImage start = warmStartFrom(last, input.incremental);
    OnlineOptimizerResult result;
    result.map = optimizeScans(input.scans, options_, resolution_, &start);
    result.map.grid = inFrameOf(result.map.grid, input.incremental);
    result.version = input.version;
    result.newest_stamp = input.newest_stamp;
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    lock.lock();
    running_ = false;
    // After a forget() during the pass, its result belongs to the map before: dropped.
    if (generation == generation_) {
      last_ = result.map.grid;
      ready_ = std::move(result);
    }
  }
}

}  // namespace octo_slice_mapper
