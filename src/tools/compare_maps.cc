// compare_maps: occupied-cell precision and recall of a map against a ground truth (both
// map_server .yaml). Prints one JSON line; exit 0, or 1 when the scores are below --min.
//
//   compare_maps MAP.yaml TRUTH.yaml [--tolerance CELLS] [--min 0.9]
#include <cstdio>
#include <iostream>
#include <string>

#include "octo_slice_mapper/map_evaluation.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: compare_maps MAP.yaml TRUTH.yaml [--tolerance CELLS] [--min SCORE]\n";
    return 2;
  }
  int tolerance = 1;
  double minimum = 0.0;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    if (arg == "--tolerance") tolerance = std::stoi(argv[i + 1]);
    else if (arg == "--min") minimum = std::stod(argv[i + 1]);
  }
  octo_slice_mapper::GridImage map, truth;
  std::string error;
  if (!octo_slice_mapper::loadPgmYaml(argv[1], &map, &error) || !octo_slice_mapper::loadPgmYaml(argv[2], &truth, &error)) {
    std::cerr << "compare_maps: " << error << "\n";
    return 2;
  }
  const auto score = octo_slice_mapper::scoreOccupancy(map, truth, tolerance);
  std::printf("{\"precision\": %.4f, \"recall\": %.4f, \"map_occupied_cells\": %zu, \"truth_observed_cells\": %zu, "
              "\"tolerance_cells\": %d}\n",
              score.precision, score.recall, score.map_occupied, score.truth_observed, tolerance);
  return (score.precision >= minimum && score.recall >= minimum) ? 0 : 1;
}
