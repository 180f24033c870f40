// The height map: per cell of the saved map's raster, the floor found under it and the top of
// what stands on it, saved beside the map as data (PREFIX_heights.yaml and .bin) and as a
// picture a person reads (PREFIX_heights.png: a colour scale with its legend).
#pragma once

#include <octomap/OcTree.h>

#include <limits>
#include <string>
#include <vector>

#include "octo_slice_mapper/internal/atomic_file.h"
#include "octo_slice_mapper/internal/floor_layer.h"
#include "octo_slice_mapper/map_io.h"

namespace octo_slice_mapper {

struct HeightMap {
  int width = 0, height = 0;  // cells; row 0 at the bottom (as GridImage)
  double resolution = 0.05;
  double origin_x = 0.0, origin_y = 0.0;  // the lower-left corner of cell (0, 0)
  std::vector<float> floor;  // m, map frame; NaN where no floor was found
  std::vector<float> top;    // m above the floor under it, of the highest occupied voxel; NaN: none
  // The floor's height where no cell is known (the last floor found under a sensor); NaN: not saved.
  double fallback_floor = std::numeric_limits<double>::quiet_NaN();
  bool empty() const { return width == 0 || height == 0; }
};

// On `frame`'s cells: the floor layer's heights, and the top of each column's highest occupied
// voxel at least `min_height` above the floor under it (the floor's own voxels excluded), the
// floor where none is known being the layer's fallback. Empty when the layer knows no cell.
HeightMap heightMapOf(const octomap::OcTree& tree, const FloorLayer& floor, const GridImage& frame,
                      double min_height = 0.05);
// The same from the occupied voxels already walked (occupiedVoxels), on a raster of their own that
// covers the floor's cells and the voxels, on the octree's lattice of cells (as /map's).
HeightMap heightMapOf(const std::vector<OccupiedVoxel>& voxels, const FloorLayer& floor, double resolution,
                      double min_height = 0.05);

// PREFIX_heights.yaml (the raster's geometry and what the data file holds), PREFIX_heights.bin
// (float32, little-endian: the floor grid, then the top grid, row by row from the bottom) and
// PREFIX_heights.png (tops coloured from 0 to 2 m above the floor, cells with a floor and nothing
// on it light grey, a legend below), into `files`.
bool addHeightMap(const HeightMap& map, const std::string& prefix, FileSet* files, std::string* error);
// A saved height map back (its .yaml, and the .bin it names beside it). False with the reason
// when either cannot be read, a key is missing or malformed, or the data's size is not the
// geometry's.
bool readHeightMap(const std::string& yaml_path, HeightMap* map, std::string* error);

}  // namespace octo_slice_mapper
