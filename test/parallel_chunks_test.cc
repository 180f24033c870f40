// Work split over the cores: every index exactly once, and results kept per chunk or piece the
// same as a serial loop's, on any number of workers.
#include "core/internal/parallel_chunks.h"

#include <gtest/gtest.h>

#include <atomic>
#include <numeric>
#include <vector>

using namespace octo_slice_mapper;

namespace {

// Per piece, the indices it was given, in order: joined in piece order they must be 0 .. n-1,
// whatever the number of workers.
std::vector<std::size_t> visitedByPieces(std::size_t n, std::size_t pieces, unsigned workers) {
  std::vector<std::vector<std::size_t>> per_piece(std::max<std::size_t>(1, pieces));
  std::atomic<std::size_t> calls{0};
  forEachPiece(n, pieces, workers, [&](std::size_t begin, std::size_t end, std::size_t piece) {
    for (std::size_t i = begin; i < end; ++i) per_piece[piece].push_back(i);
    calls++;
  });
  EXPECT_EQ(calls.load(), std::max<std::size_t>(1, pieces));
  std::vector<std::size_t> joined;
  for (const auto& p : per_piece) joined.insert(joined.end(), p.begin(), p.end());
  return joined;
}

TEST(ParallelChunks, PiecesCoverEveryIndexOnceInOrderOnAnyNumberOfWorkers) {
  for (std::size_t n : {0u, 1u, 7u, 1000u, 307200u}) {
    std::vector<std::size_t> serial(n);
    std::iota(serial.begin(), serial.end(), 0);
    for (std::size_t pieces : {1u, 3u, 19u, 64u}) {
      for (unsigned workers : {1u, 2u, 3u, 8u}) {
        EXPECT_EQ(visitedByPieces(n, pieces, workers), serial) << n << " items, " << pieces << " pieces, " << workers
                                                               << " workers";
      }
    }
  }
}

// Pieces are equal (within one index) and each runs once, with more pieces than workers.
TEST(ParallelChunks, PiecesAreEqualAndEachRunsOnce) {
  std::vector<std::atomic<int>> runs(10);
  forEachPiece(103, 10, 2, [&](std::size_t begin, std::size_t end, std::size_t piece) {
    EXPECT_GE(end - begin, 10u);
    EXPECT_LE(end - begin, 11u);
    runs[piece]++;
  });
  for (const auto& r : runs) EXPECT_EQ(r.load(), 1);
}

TEST(ParallelChunks, ChunksCoverEveryIndexOnceInOrder) {
  for (unsigned workers : {1u, 2u, 5u}) {
    std::vector<std::vector<std::size_t>> per_worker(workers);
    forEachChunk(1001, workers, [&](std::size_t begin, std::size_t end, unsigned w) {
      for (std::size_t i = begin; i < end; ++i) per_worker[w].push_back(i);
    });
    std::vector<std::size_t> joined;
    for (const auto& p : per_worker) joined.insert(joined.end(), p.begin(), p.end());
    std::vector<std::size_t> serial(1001);
    std::iota(serial.begin(), serial.end(), 0);
    EXPECT_EQ(joined, serial) << workers << " workers";
  }
  EXPECT_EQ(workersFor(4, 100, 1024), 1u) << "no more workers than chunks of min_chunk";
  EXPECT_EQ(workersFor(4, 1 << 20, 1024), 4u);
}

}  // namespace
