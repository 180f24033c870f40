// Freed memory kept for the next frame. A mapping process allocates and frees the same
// few megabytes for every frame (a depth frame's points, its rays, its updates). glibc gives the
// free memory at the top of a thread's heap back to the system once it exceeds its trim threshold
// (by default twice the largest block freed lately, a few megabytes here), so the next frame
// faulted the same pages in again: ~300 page faults per room frame, on both pipeline workers at
// once. keepFreedMemoryForReuse() sets the trim threshold to kTrimThresholdBytes and the mmap
// threshold to kMmapThresholdBytes (blocks below it come from the heaps, and their memory is
// reused; larger ones are mapped and unmapped as before).
//
// Process-wide, so it is the programs' choice (the node, the offline tool, the benchmarks that
// stand for them), not the library's. A no-op where the C library is not glibc.
#pragma once

#include <cstddef>

namespace octo_slice_mapper {

constexpr std::size_t kTrimThresholdBytes = std::size_t{64} << 20;
constexpr std::size_t kMmapThresholdBytes = std::size_t{32} << 20;

// True if the C library took both settings.
bool keepFreedMemoryForReuse();

}  // namespace octo_slice_mapper
