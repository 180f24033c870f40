// CPU time of the calling thread. Against the wall time of the same work it tells time spent
// working from time spent without a core (another thread ran, or the virtual machine stalled).
#pragma once

#include <time.h>

namespace octo_slice_mapper {

inline double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

}  // namespace octo_slice_mapper
