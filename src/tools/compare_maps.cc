// compare_maps: occupied-cell precision and recall of a map against a ground truth (both
// map_server .yaml). Prints one JSON line; exit 0, or 1 when the scores are below --min.
//
//   compare_maps MAP.yaml TRUTH.yaml [--tolerance CELLS] [--min 0.9] [--box X0 Y0 X1 Y1]
//
// --box: instead, how much of one obstacle the map has: of the truth's occupied cells whose centre
// lies in the box (map frame, m), the share the map has occupied (> 65 %) in the same place (the
// demo's table top, shelf overhang and step).
#include <cmath>
#include <cstdio>
#include <vector>
#include <iostream>
#include <string>

#include "core/internal/map_evaluation.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: compare_maps MAP.yaml TRUTH.yaml [--tolerance CELLS] [--min SCORE] [--box X0 Y0 X1 Y1]\n";
    return 2;
  }
  int tolerance = 1;
  double minimum = 0.0;
  std::vector<double> box;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    if (arg == "--tolerance") tolerance = std::stoi(argv[i + 1]);
    else if (arg == "--min") minimum = std::stod(argv[i + 1]);
    else if (arg == "--box" && i + 4 < argc) {
      for (int k = 1; k <= 4; ++k) box.push_back(std::stod(argv[i + k]));
      i += 3;
    } else {
      std::cerr << "compare_maps: unknown option " << arg << "\n";
      return 2;
    }
  }
  octo_slice_mapper::GridImage map, truth;
  std::string error;
  if (!octo_slice_mapper::loadPgmYaml(argv[1], &map, &error) || !octo_slice_mapper::loadPgmYaml(argv[2], &truth, &error)) {
    std::cerr << "compare_maps: " << error << "\n";
    return 2;
  }
  if (!box.empty()) {
    std::size_t cells = 0, occupied = 0;
    for (int j = 0; j < truth.height; ++j) {
      for (int i = 0; i < truth.width; ++i) {
        const double x = truth.origin_x + (i + 0.5) * truth.resolution, y = truth.origin_y + (j + 0.5) * truth.resolution;
        if (truth.at(i, j) <= 50 || x < box[0] || x > box[2] || y < box[1] || y > box[3]) continue;
        ++cells;
        const int mi = int(std::floor((x - map.origin_x) / map.resolution)), mj = int(std::floor((y - map.origin_y) / map.resolution));
        occupied += mi >= 0 && mj >= 0 && mi < map.width && mj < map.height && map.at(mi, mj) > 65;
      }
    }
    const double share = cells ? double(occupied) / cells : 0.0;
    std::printf("{\"box\": [%g, %g, %g, %g], \"truth_cells\": %zu, \"occupied_share\": %.4f}\n", box[0], box[1],
                box[2], box[3], cells, share);
    return cells > 0 && share >= minimum ? 0 : 1;
  }
  const auto score = octo_slice_mapper::scoreOccupancy(map, truth, tolerance);
  std::printf("{\"precision\": %.4f, \"recall\": %.4f, \"map_occupied_cells\": %zu, \"truth_observed_cells\": %zu, "
              "\"tolerance_cells\": %d}\n",
              score.precision, score.recall, score.map_occupied, score.truth_observed, tolerance);
  return (score.precision >= minimum && score.recall >= minimum) ? 0 : 1;
}
