// libFuzzer target: loading arbitrary bytes as a .bt / .ot map, then using what loaded.
#include "fuzz_helpers.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/slice_grid.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace osm = octo_slice_mapper;
  osm::fuzz::MemoryFile file(data, size);
  if (!file.ok()) return 0;
  std::string error;
  std::unique_ptr<octomap::OcTree> tree = osm::loadTree(file.path(), &error);
  if (!tree) return 0;
  std::size_t leaves = 0;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end && leaves < 100000; ++it) ++leaves;
  return 0;
}
