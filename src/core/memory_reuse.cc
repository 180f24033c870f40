#include "core/internal/memory_reuse.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace octo_slice_mapper {

bool keepFreedMemoryForReuse() {
#if defined(__GLIBC__)
  // Setting either turns off glibc's adjustment of both to the blocks freed lately.
  const bool trim = mallopt(M_TRIM_THRESHOLD, static_cast<int>(kTrimThresholdBytes)) == 1;
  const bool mmap = mallopt(M_MMAP_THRESHOLD, static_cast<int>(kMmapThresholdBytes)) == 1;
  return trim && mmap;
#else
  return false;
#endif
}

}  // namespace octo_slice_mapper
