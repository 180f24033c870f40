// Splits [0, n) into one contiguous chunk per worker and runs them on threads (the calling thread
// takes the last chunk). Chunks are in order, so results gathered per chunk and joined in chunk
// order are those of a serial loop: parallel work stays deterministic.
#pragma once

#include <algorithm>
#include <atomic>
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

// Where part `part` of [0, n) cut into `parts` equal parts begins (part == parts: n). The chunks
// and pieces below are cut so; a caller that shares pieces out its own way cuts them the same.
inline std::size_t partStart(std::size_t n, std::size_t part, std::size_t parts) { return n * part / parts; }

// fn(begin, end, worker) for worker = 0 .. workers-1, chunk `worker` of [0, n).
template <typename Fn>
void forEachChunk(std::size_t n, unsigned workers, Fn&& fn) {
  workers = std::max(1u, workers);
  const auto bound = [&](unsigned w) { return partStart(n, w, workers); };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  for (unsigned w = 0; w + 1 < workers; ++w) threads.emplace_back([&, w] { fn(bound(w), bound(w + 1), w); });
  fn(bound(workers - 1), n, workers - 1);
  for (std::thread& t : threads) t.join();
}

// fn(begin, end, piece) for piece = 0 .. pieces-1, the equal pieces of [0, n), run by `workers`
// threads (the calling thread is one) each taking the next piece as it comes free: work that is
// uneven across [0, n) stays balanced. Which thread runs a piece changes nothing: results kept
// per piece and joined in piece order are a serial loop's, whatever the number of cores.
template <typename Fn>
void forEachPiece(std::size_t n, std::size_t pieces, unsigned workers, Fn&& fn) {
  pieces = std::max<std::size_t>(1, pieces);
  workers = static_cast<unsigned>(std::clamp<std::size_t>(workers, 1, pieces));
  std::atomic<std::size_t> next{0};
  const auto run = [&] {
    for (std::size_t p = next++; p < pieces; p = next++) fn(partStart(n, p, pieces), partStart(n, p + 1, pieces), p);
  };
  std::vector<std::thread> threads;
  threads.reserve(workers - 1);
  for (unsigned w = 0; w + 1 < workers; ++w) threads.emplace_back(run);
  run();
  for (std::thread& t : threads) t.join();
}

}  // namespace octo_slice_mapper
