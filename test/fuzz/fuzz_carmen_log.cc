// libFuzzer target: the CARMEN log reader on arbitrary bytes (plain or gzip), and mapping what it reads.
#include "fuzz_helpers.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/internal/scan_inserter.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace osm = octo_slice_mapper;
  osm::fuzz::MemoryFile file(data, size);
  if (!file.ok()) return 0;
  osm::CarmenLogOptions options;
  options.max_beams = 4096;  // keeps each run short; the parser's own bound is tested elsewhere
  osm::CarmenLogReader reader(options);
  std::string error;
  if (!reader.open(file.path(), &error)) return 0;
  octomap::OcTree tree(0.1);
  osm::InsertOptions insert;
  insert.max_range = 20.0;  // bounded work per fuzz input
  osm::ScanInserter inserter(&tree, insert);
  osm::LogScan scan;
  for (int k = 0; k < 8 && reader.next(&scan); ++k) inserter.insert(scan.scan);
  return 0;
}
