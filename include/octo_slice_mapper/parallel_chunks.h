// Splits [0, n) into one contiguous chunk per worker and runs them on threads (the calling thread
// takes the last chunk). Chunks are in order, so results gathered per chunk and joined in chunk
// order are those of a serial loop: parallel work stays deterministic.
#pragma once

#include <algorithm>
#include <cstddef>
#include <thread>
#include <vector>

namespace octo_slice_mapper {

// How many workers `threads` means: 0 = the machine's cores; never more than there are chunks of
// at least `min_chunk` items.
inline unsigned workersFor(unsigned threads, std::size_t n, std::size_t min_chunk = 1024) {
  unsigned w = threads > 0 ? threads : std::max(1u, std::thread::hardware_concurrency());
  const std::size_t by_size = std::max<std::size_t>(1, n / std::max<std::size_t>(1, min_chunk));
  return static_cast<unsigned>(std::min<std::size_t>(w, by_size));
}

// fn(begin, end, worker) for worker = 0 .. workers-1, chunk `worker` of [0, n).
template <typename Fn>
void forEachChunk(std::size_t n, unsigned workers, Fn&& fn) {
  workers = std::max(1u, workers);
  const auto bound = [&](unsigned w) { return n * w / workers; };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  for (unsigned w = 0; w + 1 < workers; ++w) threads.emplace_back([&, w] { fn(bound(w), bound(w + 1), w); });
  fn(bound(workers - 1), n, workers - 1);
  for (std::thread& t : threads) t.join();
}

}  // namespace octo_slice_mapper
