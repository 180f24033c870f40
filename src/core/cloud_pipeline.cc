#include "octo_slice_mapper/cloud_pipeline.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <optional>
#include <string>

#include "core/internal/parallel_chunks.h"
#include "core/internal/thread_cpu_time.h"

namespace octo_slice_mapper {

namespace {
unsigned workerCount(unsigned threads) { return std::max(1u, workersFor(threads, ~std::size_t{0}, 1)); }
}  // namespace

CloudPipeline::CloudPipeline(MappingSession* session, unsigned threads, std::size_t max_pending)
    : session_(session), max_pending_(std::max<std::size_t>(max_pending, workerCount(threads))) {
  const unsigned n = workerCount(threads);
  preparer_bytes_ = std::make_unique<std::atomic<std::size_t>[]>(n);
  for (unsigned w = 0; w < n; ++w) preparer_bytes_[w] = 0;
  workers_.reserve(n);
  for (unsigned w = 0; w < n; ++w) workers_.emplace_back([this, w] { work(w); });
}

CloudPipeline::~CloudPipeline() {
  wait();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  for (std::thread& t : workers_) t.join();
}

void CloudPipeline::submit(SensorCloud cloud, Done done) { submitJob(std::move(cloud), std::move(done)); }

void CloudPipeline::submit(DeferredCloud cloud, Done done) { submitJob(std::move(cloud), std::move(done)); }

void CloudPipeline::submit(Scan scan, Done done) { submitJob(std::move(scan), std::move(done)); }

void CloudPipeline::submitJob(std::variant<SensorCloud, Scan, DeferredCloud> input, Done done) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return next_ticket_ - next_applied_ < max_pending_; });
  std::optional<std::uint64_t> floor_frame;
  // Under the lock: the floor layer numbers the frames in the order they are applied.
  if (!std::holds_alternative<Scan>(input)) floor_frame = session_->takeFloorFrame();
  queue_.push_back({next_ticket_++, std::move(input), std::move(done), floor_frame});
  changed_.notify_all();
}

void CloudPipeline::wait() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return next_applied_ == next_ticket_; });
}

std::size_t CloudPipeline::memoryBytes() const {
  std::size_t bytes = 0;
  for (std::size_t w = 0; w < workers_.size(); ++w) bytes += preparer_bytes_[w].load();
  return bytes;
}

void CloudPipeline::work(std::size_t worker) {
  std::unique_ptr<CloudPreparer> preparer;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stopping_ || !queue_.empty() || canApply(); });
    if (canApply()) {  // applying first: it frees a place in the pipeline
      applying_ = true;
      Ready ready = std::move(ready_.begin()->second);
      ready_.erase(ready_.begin());
      lock.unlock();
      apply(ready);
      lock.lock();
      applying_ = false;
      ++next_applied_;
      changed_.notify_all();
      continue;
    }
    if (queue_.empty()) return;  // stopping, and nothing left
    Job job = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    Ready ready = prepare(std::move(job), &preparer);
    if (preparer) preparer_bytes_[worker] = preparer->memoryBytes();
    lock.lock();
    const std::uint64_t ticket = ready.job.ticket;
    ready_.emplace(ticket, std::move(ready));
    changed_.notify_all();
  }
}

CloudPipeline::Ready CloudPipeline::prepare(Job job, std::unique_ptr<CloudPreparer>* preparer) {
  Ready ready;
  ready.start = std::chrono::steady_clock::now();
  const double cpu_start = threadCpuSeconds();
  try {
    if (!std::holds_alternative<Scan>(job.input)) session_->refreshCloudPreparer(preparer);
    if (const DeferredCloud* deferred = std::get_if<DeferredCloud>(&job.input)) {
      // From here on like any cloud (applying may need its points).
      job.input = deferred->made((*preparer)->flyingPixels());
    }
    if (const SensorCloud* cloud = std::get_if<SensorCloud>(&job.input)) {
      // With other workers preparing other frames, one thread per frame keeps the cores busy
      // without more threads than cores (and a thread started per frame).
      (*preparer)->setGroupingThreads(workers_.size() > 1 ? 1 : 0);
      ready.prepared = (*preparer)->prepare(*cloud, job.floor_frame);
      ready.map_generation = (*preparer)->mapGeneration();
    }
  } catch (const std::exception& e) {  // (out of memory): this frame is refused, the turn goes on
    ready.error = std::string("preparing the cloud failed: ") + e.what();
  }
  // Its turn at the floor layer passes if it never came to ask (refused, failed).
  if (job.floor_frame) session_->passFloorFrame(*job.floor_frame);
  ready.cpu_seconds = threadCpuSeconds() - cpu_start;
  ready.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - ready.start).count();
  ready.job = std::move(job);
  return ready;
}

void CloudPipeline::apply(Ready& ready) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = threadCpuSeconds();
  Outcome outcome;
  try {
    if (!ready.error.empty()) {
      outcome.result.error = ready.error;
    } else if (ready.prepared) {
      outcome.result = session_->insertPrepared(std::move(*ready.prepared), ready.map_generation,
                                                std::get<SensorCloud>(ready.job.input), &outcome.waited_ms);
    } else if (const Scan* scan = std::get_if<Scan>(&ready.job.input)) {
      outcome.result = session_->insert(*scan, &outcome.waited_ms);
    }
  } catch (const std::exception& e) {
    outcome.result.error = std::string("inserting failed: ") + e.what();
  }
  const auto end = std::chrono::steady_clock::now();
  outcome.seconds = std::chrono::duration<double>(end - ready.start).count();
  outcome.work_seconds = ready.seconds + std::chrono::duration<double>(end - start).count();
  outcome.cpu_seconds = ready.cpu_seconds + threadCpuSeconds() - cpu_start;
  if (ready.job.done) ready.job.done(outcome);
}

}  // namespace octo_slice_mapper
