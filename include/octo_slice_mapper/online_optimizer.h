// The global pass kept running while mapping goes on: a worker thread takes the newest
// input (the kept scans and the map to start from), runs the hill climbing on it and leaves the
// result for the mapping side to publish. Submitting never waits for a pass: an input not started
// yet is replaced by a newer one, at most one pass runs at a time, and each result says which
// input (version) it answers.
//
// Each pass starts from the last one's state (OptimizedMap::state), the slice where that knew
// nothing. When that pass converged and the new input's scans begin with the last input's (the
// scan store only appended), the first sweep looks only at the cells the new scans' beams cross
// and the cells the last state did not know (GlobalOptimizer::cellsToRevisit): the same map as a
// full first sweep, at a fraction of its cost (on a Freiburg 079-sized map a full sweep takes
// seconds). Otherwise the pass looks at every cell. The beam index is then extended by the new
// scans instead of built anew when they stay within the extent indexed so far (building it is
// most of a pass's time on a large map).
// The pass runs at a lower priority (Linux nice 10) than the thread that inserts scans, on
// GlobalOptimizerOptions::threads workers (the node gives it one: ~online_optimize_threads).
#pragma once

#include <atomic>
#include <condition_variable>
#include <memory>
#include <cstdint>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "octo_slice_mapper/optimized_map.h"

namespace octo_slice_mapper {

struct OnlineOptimizerInput {
  std::vector<StoredScan> scans;
  GridImage incremental;  // the incremental slice: the start where no earlier result knows a cell
  std::uint64_t version = 0;
  double newest_stamp = 0.0;  // of the newest scan in `scans` (s), handed back with the result
  // The pass's options when they may change during a session (reconfigure); else the
  // constructor's. A pass with other options than the last (options_version) looks at every cell.
  std::optional<GlobalOptimizerOptions> options;
  std::uint64_t options_version = 0;
  // Cells of `incremental` (indices) with an obstacle beside the pass's layers (Mapper::
  // cellsBesidePass): shown occupied in the result, not part of the pass's state.
  std::vector<std::size_t> beside;
};

struct OnlineOptimizerResult {
  OptimizedMap map;  // drawn in the frame of the input's incremental slice
  GridImage shown;   // map.grid with the input's obstacles beside the pass: what ~optimized_map shows
  std::uint64_t version = 0;
  double newest_stamp = 0.0;
  double seconds = 0.0;  // the pass, from taking its input to leaving its result
  std::size_t scans_revisited_from = 0;  // 0: a full first sweep; else the first new scan
};

// The start of the next pass: the last result where it knows a cell (the pass goes on from where
// it stopped), the incremental slice elsewhere (cells new scans reached), in the slice's frame.
GridImage warmStartFrom(const GridImage& last_result, const GridImage& incremental);

class OnlineOptimizer {
 public:
  OnlineOptimizer(const GlobalOptimizerOptions& options, double resolution);
  ~OnlineOptimizer();  // waits for a running pass, starts no other
  OnlineOptimizer(const OnlineOptimizer&) = delete;
  OnlineOptimizer& operator=(const OnlineOptimizer&) = delete;

  void submit(OnlineOptimizerInput input);
  // The newest result not taken yet.
  std::optional<OnlineOptimizerResult> take();
  // A pass is running or an input waits for one.
  bool busy() const;
  // Forgets the last result (after the map was reset or replaced): the next pass starts from the
  // incremental slice alone.
  void forget();

 private:
  void run();

  const GlobalOptimizerOptions options_;
  const double resolution_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<OnlineOptimizerInput> waiting_;
  std::optional<OnlineOptimizerResult> ready_;
  GridImage last_;  // the last pass's state (OptimizedMap::state): the next one's start
  // Of the last pass's input, to tell whether the next one only appended scans to it.
  std::size_t last_scan_count_ = 0;
  std::optional<StoredScan> last_first_scan_, last_last_scan_;
  bool last_converged_ = false;
  std::uint64_t last_options_version_ = 0;
  // The last pass's optimizer, whose beam index the next pass extends by the scans kept since
  // when they stay within its extent (GlobalOptimizer::extend: the same index as a new build, at
  // the cost of the new beams). Only the worker touches it.
  std::unique_ptr<GlobalOptimizer> optimizer_;
  std::uint64_t generation_ = 0;  // counts forget()s
  bool running_ = false, stopping_ = false;
  // Set with stopping_: a running pass ends before its next sweep (a full pass of a building's
  // scans takes many seconds, and the node's shutdown waits for this worker).
  std::atomic<bool> stop_pass_{false};
  std::thread worker_;  // last: started once the rest is set up
};

}  // namespace octo_slice_mapper
