// Depth frames into a MappingSession on several threads: each frame's updates are
// worked out (grouping its points and tracing their rays, which reads no map: CloudPreparer) by
// whichever worker is free, frames in parallel, and applied to the map strictly in the order
// they were submitted, so the map is the one inserting them one by one gives. Scans submitted
// in between keep their place in that order. A worker whose frame is prepared before its turn
// does not wait for it: it leaves the result and prepares the next frame; whoever finds the next
// result in turn applies it (one applier at a time).
//
// Why frames in parallel: a 640 x 480 frame of a room takes 20-30 ms of one core, and splitting
// one frame's tracing across the two cores costs about half again its CPU time; two frames at once
// cost what they cost one after the other.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "octo_slice_mapper/mapping_session.h"

namespace octo_slice_mapper {

class CloudPipeline {
 public:
  struct Outcome {
    InsertResult result;
    double seconds = 0.0;       // wall time from the start of its preparation to applied
    double work_seconds = 0.0;  // wall time of its preparation and application (without waiting)
    double cpu_seconds = 0.0;   // CPU time of its preparation and application
    double waited_ms = 0.0;    // for the session's lock
  };
  // Called on a worker thread right after the job was applied, in submission order.
  using Done = std::function<void(const Outcome&)>;

  // `threads` workers (0: the machine's cores). submit() waits while `max_pending` jobs are
  // submitted and not yet applied (at least `threads`): a bound on the memory frames hold.
  CloudPipeline(MappingSession* session, unsigned threads, std::size_t max_pending);
  // Applies everything submitted, then stops.
  ~CloudPipeline();
  CloudPipeline(const CloudPipeline&) = delete;
  CloudPipeline& operator=(const CloudPipeline&) = delete;

  void submit(SensorCloud cloud, Done done = {});
  // Its points made on the worker; an exception from `points` refuses the frame (in its turn).
  void submit(DeferredCloud cloud, Done done = {});
  // A scan applied after every job submitted before it (for a caller that wants the order of a
  // log kept, as the offline tool does); no work of its own is done in parallel.
  void submit(Scan scan, Done done = {});
  // Returns once every job submitted so far is applied (and its Done called).
  void wait();
  unsigned threads() const { return static_cast<unsigned>(workers_.size()); }
  // What the workers' preparers hold (each its own evidence window), as of their last frame.
  std::size_t memoryBytes() const;

 private:
  struct Job {
    std::uint64_t ticket;
    std::variant<SensorCloud, Scan, DeferredCloud> input;  // a DeferredCloud is a SensorCloud once prepared
    Done done;
    std::optional<std::uint64_t> floor_frame;  // a cloud's number at the floor layer, taken in submission order
  };
  // A job ready to be applied: a cloud's prepared updates (with the preparer's map generation).
  struct Ready {
    Job job;
    std::optional<PreparedCloud> prepared;
    std::uint64_t map_generation = 0;
    std::string error;  // preparing failed
    std::chrono::steady_clock::time_point start;
    double seconds = 0.0, cpu_seconds = 0.0;  // of the preparation
  };
  void submitJob(std::variant<SensorCloud, Scan, DeferredCloud> input, Done done);
  void work(std::size_t worker);
  Ready prepare(Job job, std::unique_ptr<CloudPreparer>* preparer);
  void apply(Ready& ready);
  // Whether a worker can apply now: no one does and the next job in turn is ready.
  bool canApply() const { return !applying_ && !ready_.empty() && ready_.begin()->first == next_applied_; }

  MappingSession* session_;
  const std::size_t max_pending_;
  std::mutex mutex_;  // guards everything below
  std::condition_variable changed_;
  std::deque<Job> queue_;  // submitted, not yet taken by a worker
  std::map<std::uint64_t, Ready> ready_;  // prepared, by ticket
  bool applying_ = false;
  std::uint64_t next_ticket_ = 0;   // the next submit()'s
  std::uint64_t next_applied_ = 0;  // the ticket whose turn it is to be applied
  bool stopping_ = false;
  std::unique_ptr<std::atomic<std::size_t>[]> preparer_bytes_;  // per worker, written by it
  std::vector<std::thread> workers_;
};

}  // namespace octo_slice_mapper
