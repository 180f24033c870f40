// A mapping session as both the node and octo_slice_map run it: the Mapper behind one
// lock, and the workflows around it written once: saving (with or without the global pass),
// the global pass on request, applying its result to the map, reset and load, and the input of
// the background pass. Insertion runs on one thread while a save or a pass runs on another: the
// slow work happens on a snapshot outside the lock (the octree lent, see MapSnapshot).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/online_optimizer.h"

namespace octo_slice_mapper {

struct SessionOptions {
  // Every save runs the global pass: PREFIX.* is its map, PREFIX_incremental.* the incremental one.
  bool optimize_on_save = true;
  bool warm_start = true;         // the saves' global pass starts from the incremental map
  // The global pass's result is written into the octree's slice band (so .bt export carries it).
  bool write_optimized_into_map = true;
};

struct SaveOutcome {
  bool ok = false;
  std::string error;
  std::vector<std::string> files;          // written
  std::optional<OptimizedMap> optimized;   // when the save ran the global pass
  std::string note;                        // e.g. why a requested global pass was skipped
};

class MappingSession {
 public:
  MappingSession(const MapperOptions& mapper, const SessionOptions& session);

  // Runs f(Mapper&) under the session's lock: insertion and reading the slice go through here.
  template <typename F>
  decltype(auto) withMapper(F&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(mapper_);
  }
  template <typename F>
  decltype(auto) withMapper(F&& f) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return f(static_cast<const Mapper&>(mapper_));
  }
  // Inserts under the lock; `waited_ms` gets how long the lock took. A cloud's updates are worked
  // out before, outside the lock (Mapper::cloudPreparer), so scans can be inserted from another
  // thread meanwhile; clouds go in one at a time.
  InsertResult insert(const Scan& scan, double* waited_ms = nullptr);
  InsertResult insert(const SensorCloud& cloud, double* waited_ms = nullptr);
  // A cloud's two steps, for callers that prepare frames in parallel (CloudPipeline), each with
  // a preparer of its own: the preparer kept current (made anew when the map was reset, loaded or
  // reconfigured since it was made), and a frame it prepared applied under the lock (inserted
  // anew when the map changed meanwhile).
  void refreshCloudPreparer(std::unique_ptr<CloudPreparer>* preparer);
  // `map_generation`: the preparer's mapGeneration() when it prepared the frame.
  InsertResult insertPrepared(PreparedCloud prepared, std::uint64_t map_generation, const SensorCloud& cloud,
                              double* waited_ms = nullptr);

  // Writes PREFIX.{bt,ot,pcd,pgm,yaml,png}, the best map, and PREFIX_incremental.{pgm,yaml,png}, the
  // incremental slice, as one set (saveBestMapSet). With `with_global_pass` (the node gives
  // optimize_on_save) and kept scans, the best map is the global pass's, and the result goes into
  // the map when `write_optimized_into_map`; otherwise it is the incremental map. PREFIX is used
  // as given (resolve it first, see save_path.h).
  SaveOutcome save(const std::string& prefix, bool with_global_pass, const ProgressFn& progress = {});
  // The global pass over the kept scans, applied to the map (if write_optimized_into_map);
  // nothing when no scans are kept.
  std::optional<OptimizedMap> optimize(bool warm_start, const ProgressFn& progress = {});
  // The occupied voxels (occupiedVoxels, map_io.h) of the map as it is now, and changes() as of
  // them. The octree is walked outside the lock (lent, as a save lends it), so insertion goes on
  // meanwhile. False, with nothing done, while a save, pass, reset or load runs: ask again later.
  bool occupiedVoxels(std::vector<OccupiedVoxel>* voxels, std::uint64_t* changes);
  void reset();
  bool load(const std::string& path, std::string* error);
  // Mapper::reconfigure, waiting for a running save; false with the reason for impossible values
  // (nothing changed then). The background pass takes the new forward model with its next input.
  bool reconfigure(const MapperOptions& wanted, std::string* error);
  // Mapper::clearBox, waiting for a running save; false with the reason for a box out of range.
  bool clearBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Mapper::Cleared* cleared, std::string* error);

  // Changes with every change to the map by scans, clouds, reset, load and optimize(); not by
  // what a save's own global pass writes back (so a save on shutdown can tell it would repeat
  // the last one).
  std::uint64_t version() const;
  // Changes with every change at all (for publishers).
  std::uint64_t changes() const;
  // True when `prefix` was the last save's and the map has not changed since.
  bool savedAlready(const std::string& prefix) const;
  // The background pass's input when the map changed since the last one was taken (its
  // newest_stamp: the newest inserted scan's).
  std::optional<OnlineOptimizerInput> onlinePassInput();
  // The longest a save, pass, reset or input copy held the lock (ms): scans waited that long.
  double longestLockMs() const;
  // The most CPU time (ms) the thread holding the lock spent in one hold: the work done under it,
  // without the time the machine gave that thread no core.
  double longestLockCpuMs() const;

  // What preparing clouds outside the map's lock holds (0 before the first cloud): a second
  // inserter's evidence window, besides the mapper's own.
  std::size_t cloudPreparerBytes();

  // The floor layer, which guards itself: readable from any thread without the map's lock.
  const FloorLayer& floor() const { return mapper_.floor(); }
  // Mapper::takeFloorFrame and passFloorFrame, without the lock (the layer guards itself).
  std::uint64_t takeFloorFrame() { return mapper_.takeFloorFrame(); }
  void passFloorFrame(std::uint64_t frame) { mapper_.passFloorFrame(frame); }
  // The mapper without the lock: only for a single-threaded user (the offline tool, tests).
  Mapper& mapperUnlocked() { return mapper_; }

  const SessionOptions& options() const { return options_; }
  // The mapper's options as they are now (reconfigure() changes the models and the band).
  MapperOptions mapperOptions() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return mapper_.options();
  }

 private:
  class Lock;  // the lock, timed
  class Loan;  // ends a snapshot's loan of the octree on every way out
  // Writes the pass's result into the map in strips of rows, each under the lock on its own, so
  // that scans are inserted in between.
  void applyOptimized(const GridImage& grid);
  InsertResult recordInsert(InsertResult result);

  const SessionOptions options_;
  mutable std::mutex mutex_;  // guards everything below
  Mapper mapper_;
  std::mutex one_at_a_time_;  // one save / optimize / reset / load at a time
  std::uint64_t version_ = 0, changes_ = 0;
  std::string last_saved_prefix_;
  std::uint64_t last_saved_version_ = 0;
  std::uint64_t online_input_version_ = ~std::uint64_t{0};
  double newest_stamp_ = 0.0;  // of the scans inserted
  std::uint64_t options_version_ = 0;  // counts reconfigure()s
  double longest_lock_ms_ = 0.0;
  double longest_lock_cpu_ms_ = 0.0;
  std::uint64_t generation_ = 0;  // counts reset()s and load()s: the scan store began anew

  std::mutex cloud_mutex_;  // one cloud prepared at a time; guards the preparer; taken before mutex_
  std::unique_ptr<CloudPreparer> cloud_preparer_;

  // The background pass's copy of the kept scans, brought up to date under the lock by appending
  // the scans kept since (copying all 2 400 scans of 1081 beams under it held scans back by 5 to
  // 10 ms, once per pass); handed to the pass by a copy outside the lock.
  std::mutex online_mutex_;  // guards the three below; taken before mutex_
  std::vector<StoredScan> online_scans_;
  std::uint64_t online_rewrites_ = ~std::uint64_t{0}, online_generation_ = ~std::uint64_t{0};
};

}  // namespace octo_slice_mapper
