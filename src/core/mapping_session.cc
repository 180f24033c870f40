#include "octo_slice_mapper/mapping_session.h"

#include "octo_slice_mapper/internal/height_map.h"

#include <algorithm>
#include <utility>

#include "core/internal/thread_cpu_time.h"

namespace octo_slice_mapper {

// The session's lock for work other than insertion; how long it was held is kept, because every
// scan arriving meanwhile waited that long. So is the CPU time spent holding it: the wall time
// also counts a stall of the machine (61 ms once in CI, with no scan waiting meanwhile).
class MappingSession::Lock {
 public:
  explicit Lock(MappingSession* session)
      : session_(session), lock_(session->mutex_), since_(std::chrono::steady_clock::now()),
        cpu_since_(threadCpuSeconds()) {}
  ~Lock() {
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since_).count();
    session_->longest_lock_ms_ = std::max(session_->longest_lock_ms_, ms);
    session_->longest_lock_cpu_ms_ = std::max(session_->longest_lock_cpu_ms_, 1000.0 * (threadCpuSeconds() - cpu_since_));
  }
  Lock(const Lock&) = delete;
  Lock& operator=(const Lock&) = delete;

 private:
  MappingSession* session_;
  std::lock_guard<std::mutex> lock_;
  std::chrono::steady_clock::time_point since_;
  double cpu_since_;
};

MappingSession::MappingSession(const MapperOptions& mapper, const SessionOptions& session)
    : options_(session), mapper_(mapper) {}

InsertResult MappingSession::recordInsert(InsertResult result) {
  if (result.ok() && result.voxels_updated > 0) version_++, changes_++;
  return result;
}

InsertResult MappingSession::insert(const Scan& scan, double* waited_ms) {
  const auto start = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (waited_ms) *waited_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  InsertResult result = recordInsert(mapper_.insert(scan));
  if (result.ok()) newest_stamp_ = scan.stamp;  // the latest, not the largest: a bag may loop
  return result;
}

InsertResult MappingSession::insert(const SensorCloud& cloud, double* waited_ms) {
  // Most of a frame's time is working out its updates, which does not read the map: done outside
  // the lock, so that scans are inserted meanwhile; only applying them holds it.
  std::lock_guard<std::mutex> one_cloud(cloud_mutex_);
  refreshCloudPreparer(&cloud_preparer_);
  return insertPrepared(cloud_preparer_->prepare(cloud), cloud_preparer_->mapGeneration(), cloud, waited_ms);
}

void MappingSession::refreshCloudPreparer(std::unique_ptr<CloudPreparer>* preparer) {
  // Without the lock while the preparer is current: a worker starting a frame must not wait for
  // another's frame being applied (3-4 ms of a room frame's). A reset between this check and the
  // frame's turn is caught when it is applied (insertPrepared).
  if (*preparer && (*preparer)->mapGeneration() == mapper_.inserterGeneration()) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!*preparer || (*preparer)->mapGeneration() != mapper_.inserterGeneration()) {
    *preparer = mapper_.cloudPreparer();  // an empty octree and an inserter: cheap
  }
}

InsertResult MappingSession::insertPrepared(PreparedCloud prepared, std::uint64_t map_generation,
                                            const SensorCloud& cloud, double* waited_ms) {
  const auto start = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (waited_ms) *waited_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  InsertResult result;
  const std::optional<std::uint64_t> floor_frame = prepared.floor_frame;
  if (mapper_.insertPrepared(std::move(prepared), map_generation, &result)) return recordInsert(result);
  // Reset, loaded or reconfigured while it was prepared: inserted the ordinary way (as the same
  // frame at the floor layer, whose turn has come: nothing there waits).
  return recordInsert(mapper_.insert(cloud, floor_frame));
}

// Scans keep going into the insertion cache while the octree is lent (Mapper::snapshot); the loan
// ends under the lock when this goes out of scope, on every way out.
class MappingSession::Loan {
 public:
  explicit Loan(MappingSession* session) : session_(session) {}
  ~Loan() {
    Lock lock(session_);
    session_->mapper_.endSnapshot();
  }
  Loan(const Loan&) = delete;
  Loan& operator=(const Loan&) = delete;

 private:
  MappingSession* session_;
};

SaveOutcome MappingSession::save(const std::string& prefix, bool with_global_pass, const ProgressFn& progress) {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  MapSnapshot snapshot;
  GlobalOptimizerOptions pass_options;
  double resolution = 0.0;
  std::uint64_t saved_version = 0;
  {
    Lock lock(this);
    snapshot = mapper_.snapshot(with_global_pass);
    pass_options = mapper_.options().optimizer;
    resolution = mapper_.options().resolution;
    saved_version = version_;
  }
  SaveOutcome out;
  {
    Loan loan(this);
    if (with_global_pass && snapshot.scans.empty()) {
      out.note =
          "global pass skipped: it works on laser scans, and none are kept (depth clouds only, keep_scans false, "
          "or nothing inserted): the incremental map saved";
    } else if (with_global_pass) {
      out.optimized = optimizeScans(snapshot.scans, pass_options, resolution,
                                    options_.warm_start ? &snapshot.slice : nullptr, progress);
    }
    const PassBand band = PassBand::of(snapshot.scans, *snapshot.tree, snapshot.band_lo, snapshot.band_hi);
    // The floor layer guards itself: read here, off the map's lock, as the lent octree is.
    const HeightMap heights = heightMapOf(*snapshot.tree, mapper_.floor(), snapshot.slice);
    out.ok = saveBestMapSet(*snapshot.tree, band, out.optimized ? &out.optimized->grid : nullptr, snapshot.slice, prefix,
                            &out.files, &out.error, &heights);
  }
  if (out.optimized) applyOptimized(out.optimized->grid);
  if (out.ok) {
    Lock lock(this);
    last_saved_prefix_ = prefix;
    last_saved_version_ = saved_version;
  }
  return out;
}

bool MappingSession::occupiedVoxels(std::vector<OccupiedVoxel>* voxels, std::uint64_t* changes) {
  std::unique_lock<std::mutex> one(one_at_a_time_, std::try_to_lock);
  if (!one.owns_lock()) return false;
  MapSnapshot snapshot;
  {
    Lock lock(this);
    snapshot = mapper_.snapshot(/*with_scans=*/false, /*with_slice=*/false);
    *changes = changes_;
  }
  Loan loan(this);
  *voxels = octo_slice_mapper::occupiedVoxels(*snapshot.tree);
  return true;
}

std::optional<OptimizedMap> MappingSession::optimize(bool warm_start, const ProgressFn& progress) {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  MapSnapshot input;
  GlobalOptimizerOptions pass_options;
  double resolution = 0.0;
  {
    // The scans and the slice only: the pass needs neither the octree nor a flush of the cache.
    Lock lock(this);
    input = mapper_.optimizationInput();
    pass_options = mapper_.options().optimizer;
    resolution = mapper_.options().resolution;
  }
  if (input.scans.empty()) return std::nullopt;
  OptimizedMap optimized =
      optimizeScans(input.scans, pass_options, resolution, warm_start ? &input.slice : nullptr, progress);
  applyOptimized(optimized.grid);
  if (options_.write_optimized_into_map) {
    Lock lock(this);
    version_++;
  }
  return optimized;
}

void MappingSession::applyOptimized(const GridImage& grid) {
  if (!options_.write_optimized_into_map) return;
  PassBand band;
  {
    Lock lock(this);
    band = mapper_.passBand();
  }
  const int rows = std::max(1, 4096 / std::max(1, grid.width));
  for (int j0 = 0; j0 < grid.height; j0 += rows) {
    GridImage strip;  // not a copy of `grid`: that would copy all its cells once per strip
    strip.width = grid.width;
    strip.resolution = grid.resolution;
    strip.origin_x = grid.origin_x;
    strip.height = std::min(rows, grid.height - j0);
    strip.origin_y = grid.origin_y + j0 * grid.resolution;
    strip.cells.assign(grid.cells.begin() + std::size_t(j0) * grid.width,
                       grid.cells.begin() + std::size_t(j0 + strip.height) * grid.width);
    Lock lock(this);
    mapper_.applyOptimized(strip, band);
    changes_++;
  }
}

void MappingSession::reset() {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  Lock lock(this);
  mapper_.reset();
  newest_stamp_ = 0.0;
  generation_++;
  version_++, changes_++;
}

std::size_t MappingSession::cloudPreparerBytes() {
  std::lock_guard<std::mutex> one_cloud(cloud_mutex_);
  return cloud_preparer_ ? cloud_preparer_->memoryBytes() : 0;
}

bool MappingSession::reconfigure(const MapperOptions& wanted, std::string* error) {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  Lock lock(this);
  if (!mapper_.reconfigure(wanted, error)) return false;
  options_version_++;
  version_++, changes_++;
  return true;
}

bool MappingSession::clearBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Mapper::Cleared* cleared,
                              std::string* error) {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  Lock lock(this);
  if (!mapper_.clearBox(min, max, cleared, error)) return false;
  version_++, changes_++;
  return true;
}

bool MappingSession::load(const std::string& path, std::string* error) {
  std::lock_guard<std::mutex> one(one_at_a_time_);
  Lock lock(this);
  if (!mapper_.load(path, error)) return false;
  generation_++;
  version_++, changes_++;
  return true;
}

std::uint64_t MappingSession::version() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return version_;
}

std::uint64_t MappingSession::changes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return changes_;
}

bool MappingSession::savedAlready(const std::string& prefix) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return prefix == last_saved_prefix_ && version_ == last_saved_version_;
}

std::optional<OnlineOptimizerInput> MappingSession::onlinePassInput() {
  std::lock_guard<std::mutex> online(online_mutex_);
  OnlineOptimizerInput input;
  {
    Lock lock(this);
    const ScanStore& store = mapper_.scanStore();
    if (version_ == online_input_version_ || store.scans().empty()) return std::nullopt;
    online_input_version_ = version_;
    const std::vector<StoredScan>& kept = store.scans();
    if (online_generation_ != generation_ || online_rewrites_ != store.rewrites() || online_scans_.size() > kept.size()) {
      online_scans_ = kept;  // thinned, cleared or begun anew: the whole copy, rarely
      online_generation_ = generation_;
      online_rewrites_ = store.rewrites();
    } else {
      online_scans_.insert(online_scans_.end(), kept.begin() + static_cast<std::ptrdiff_t>(online_scans_.size()),
                           kept.end());
    }
    input.incremental = gridImageOf(mapper_.slice());
    input.beside = mapper_.cellsBesidePass(input.incremental);
    input.version = version_;
    input.newest_stamp = newest_stamp_;
    input.options = mapper_.options().optimizer;
    input.options_version = options_version_;
  }
  input.scans = online_scans_;
  return input;
}

double MappingSession::longestLockMs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return longest_lock_ms_;
}

double MappingSession::longestLockCpuMs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return longest_lock_cpu_ms_;
}

}  // namespace octo_slice_mapper
