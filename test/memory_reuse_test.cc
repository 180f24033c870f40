// keepFreedMemoryForReuse: a frame's blocks, freed and allocated again on a worker thread, come
// back without page faults, where glibc's adaptive default gives them back every frame. Each case
// runs in a fresh process (this binary again, told by an environment variable), since the
// setting is process-wide and what glibc does by default depends on what the process freed before.
#include "core/internal/memory_reuse.h"

#include <gtest/gtest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

using namespace octo_slice_mapper;

// AddressSanitizer brings its own allocator (scripts/test-sanitizers): glibc's settings do nothing there.
#if defined(__SANITIZE_ADDRESS__)
#define OSM_OWN_ALLOCATOR 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define OSM_OWN_ALLOCATOR 1
#endif
#endif

namespace {

constexpr std::size_t kBlocksPerFrame = 40, kBlockBytes = 256u << 10;

// Page faults of frames 3..`frames` on a new thread, each allocating 40 blocks of 256 KB (10 MB;
// a room frame's points, rays, updates and the grouping's pieces come to 6-7 MB), touching every
// page and freeing them all.
long faultsOfLaterFrames(int frames) {
  long faults = 0;
  std::thread worker([&] {
    const std::vector<std::size_t> sizes(kBlocksPerFrame, kBlockBytes);
    rusage before{};
    for (int f = 0; f < frames; ++f) {
      if (f == 2) getrusage(RUSAGE_THREAD, &before);
      std::vector<char*> blocks;
      for (std::size_t size : sizes) {
        char* block = static_cast<char*>(std::malloc(size));
        for (std::size_t i = 0; i < size; i += 4096) block[i] = static_cast<char>(f);
        blocks.push_back(block);
      }
      for (char* block : blocks) std::free(block);
    }
    rusage after{};
    getrusage(RUSAGE_THREAD, &after);
    faults = after.ru_minflt - before.ru_minflt;
  });
  worker.join();
  return faults;
}

constexpr const char* kCaseVariable = "OSM_MEMORY_REUSE_CASE";

// In the re-run process, before main: the case's page faults on stdout, then exit.
const bool kRanCase = [] {
  const char* which = std::getenv(kCaseVariable);
  if (!which) return false;
  const bool keep = std::strcmp(which, "keep") == 0;
  if (keep && !keepFreedMemoryForReuse()) std::_Exit(3);
  std::printf("%ld\n", faultsOfLaterFrames(10));
  std::fflush(stdout);
  std::_Exit(0);
}();

// This binary run again with the case in its environment; -1 if that failed.
long faultsInFreshProcess(const std::string& which) {
  const std::string command = std::string(kCaseVariable) + "=" + which + " /proc/" + std::to_string(getpid()) + "/exe";
  FILE* out = popen(command.c_str(), "r");
  if (!out) return -1;
  long faults = -1;
  if (std::fscanf(out, "%ld", &faults) != 1) faults = -1;
  return pclose(out) == 0 ? faults : -1;
}

}  // namespace

TEST(MemoryReuse, AFramesBlocksComeBackWithoutPageFaults) {
#if !defined(__GLIBC__) || defined(OSM_OWN_ALLOCATOR)
  GTEST_SKIP() << "only glibc's allocator is set (under AddressSanitizer malloc is the sanitizer's)";
#endif
  const std::size_t pages_per_frame = kBlocksPerFrame * kBlockBytes / 4096;
  const long by_default = faultsInFreshProcess("default");
  const long kept = faultsInFreshProcess("keep");
  ASSERT_GE(by_default, 0);
  ASSERT_GE(kept, 0) << "the C library refused the settings";
  // By default part of each frame's pages is given back and faulted in again (3 300 of the 8 later
  // frames' 20 000 here): more than a frame's worth.
  EXPECT_GT(by_default, static_cast<long>(pages_per_frame));
  // Kept, the memory stays: a few faults at most.
  EXPECT_LT(kept, static_cast<long>(pages_per_frame / 10)) << by_default << " page faults by default";
}
