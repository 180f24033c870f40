// Saving and loading maps: OctoMap .bt/.ot, map_server .pgm/.yaml, a .png picture, and the
// occupied voxels as a PCL .pcd point cloud.
#pragma once

#include <octomap/OcTree.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "octo_slice_mapper/internal/atomic_file.h"
#include "octo_slice_mapper/slice_grid.h"

namespace pcl {
struct PCLPointCloud2;
}

namespace octo_slice_mapper {

// .bt: OctoMap's compact binary (max-likelihood). Written with writeBinaryConst so the live
// probabilistic tree is not thresholded or pruned by saving.
bool saveBinaryTree(const octomap::OcTree& tree, const std::string& path, std::string* error);
// .ot: the full tree with log-odds (resume mapping exactly where it stopped).
bool saveFullTree(const octomap::OcTree& tree, const std::string& path, std::string* error);
// Loads .bt or .ot (by content, not by name). Returns null with a reason on any problem.
std::unique_ptr<octomap::OcTree> loadTree(const std::string& path, std::string* error);

// A plain 2D occupancy raster in map_server conventions, independent of where it came from.
struct GridImage {
  int width = 0, height = 0;
  double resolution = 0.05;
  double origin_x = 0.0, origin_y = 0.0;  // lower-left corner of cell (0, 0)
  std::vector<std::int8_t> cells;         // row-major, row 0 at the bottom; 0..100 or -1
  std::int8_t at(int i, int j) const { return cells[std::size_t(j) * width + i]; }
};
// The known area of `grid` (plus `margin_cells` of unknown around it); empty if nothing is known.
GridImage cropToKnown(const GridImage& grid, int margin_cells = 5);
// The slice's known area (plus `margin_cells` of unknown around it) as a raster.
GridImage gridImageOf(const SliceGrid& slice, int margin_cells = 5);
// `grid` redrawn in `frame`'s extent (both on the same lattice of cells), grown where `grid` knows
// cells outside it. Two maps of one place drawn in one frame overlay cell for cell, and their
// pictures come out at the same scale. Returned unchanged if the resolutions differ.
GridImage inFrameOf(const GridImage& grid, const GridImage& frame);

// map_server thresholds: occupied above 0.65, free below 0.196 (its defaults).
struct PgmOptions {
  double occupied_thresh = 0.65;
  double free_thresh = 0.196;
};
// Writes PREFIX.pgm and PREFIX.yaml (trinary pgm: 0 occupied, 254 free, 205 unknown).
bool savePgmYaml(const GridImage& grid, const std::string& prefix, std::string* error,
                 const PgmOptions& options = {});
// Reads a map_server .yaml + its .pgm back (used by evaluation tools and tests).
bool loadPgmYaml(const std::string& yaml_path, GridImage* grid, std::string* error);
// A picture for people: grey levels by probability (white free, black occupied), unknown in a
// light blue-grey, north up.
bool savePng(const GridImage& grid, const std::string& path, std::string* error);

// An occupied voxel of the octree at its resolution: its centre and occupancy probability.
struct OccupiedVoxel {
  float x, y, z;
  float probability;
};
// Every occupied voxel of `tree` (occupied by the tree's own threshold, as a .bt export keeps
// it), one per leaf-sized voxel: a pruned node stands for each leaf it holds, with its
// probability. In the tree's leaf order.
std::vector<OccupiedVoxel> occupiedVoxels(const octomap::OcTree& tree);
// `points` points of four packed FLOAT32 fields named `names` (x, y, z and one more), 16 bytes
// each from `data` on, as a PCL cloud of one row, dense.
void fourFloatCloud(const void* data, std::size_t points, const std::array<const char*, 4>& names,
                    pcl::PCLPointCloud2* cloud);
// `voxels` as such a cloud: fields x, y, z, occupancy. What PREFIX.pcd holds and
// ~occupied_voxels carries.
void occupiedVoxelsCloud(const std::vector<OccupiedVoxel>& voxels, pcl::PCLPointCloud2* cloud);
// That cloud as a PCL point cloud file: binary, the header written by PCL's PCDWriter
// (pcl_viewer, CloudCompare and pcl::io::loadPCDFile read it).
bool addPointCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& path, FileSet* files,
                   std::string* error);
bool savePointCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& path, std::string* error);

// The same formats serialised into a FileSet, to be written together with writeFilesAtomically
// (atomic_file.h): all or none of a set's files replace what was there.
bool addBinaryTree(const octomap::OcTree& tree, const std::string& path, FileSet* files, std::string* error);
bool addFullTree(const octomap::OcTree& tree, const std::string& path, FileSet* files, std::string* error);
bool addPgmYaml(const GridImage& grid, const std::string& prefix, FileSet* files, std::string* error,
                const PgmOptions& options = {});
bool addPng(const GridImage& grid, const std::string& path, FileSet* files, std::string* error);

// Writes PREFIX.bt, .ot, .pcd (from `tree`), .pgm, .yaml and .png (from `grid`) and, given
// `incremental`, PREFIX_incremental.{pgm,yaml,png} from it, as one set: on any failure none of
// them replaces the previous file. Appends the files written. Every file carries the set's save
// id (a hash of the set's content; see readSaveId).
// With `heights` (not empty), PREFIX_heights.{yaml,bin,png} too (height_map.h).
struct HeightMap;
bool saveMapSet(const octomap::OcTree& tree, const GridImage& grid, const std::string& prefix,
                std::vector<std::string>* written, std::string* error, const GridImage* incremental = nullptr,
                const HeightMap* heights = nullptr);

// The save id a file of a set carries: 16 hex digits, "" if it has none (or cannot be read).
std::string readSaveId(const std::string& path);

// The files of PREFIX's set that exist (PREFIX.bt, .ot, .pcd, .pgm, .yaml, .png and
// PREFIX_incremental.pgm, .yaml, .png), each with its save id.
// Each file is renamed into place whole, but a kill between the renames of one save leaves files
// of the new set beside the previous set's: then their ids differ.
struct MapSetCheck {
  std::vector<std::pair<std::string, std::string>> files;  // (path, save id)
  bool mixed() const;
  std::string describe() const;  // which files come from which save, e.g. "map.bt map.ot are from save 1f…; map.png …"
};
MapSetCheck checkMapSet(const std::string& prefix);
// PATH without the ending of a set's file (.bt, .ot, .pcd, .pgm, .yaml, .png, _incremental.pgm, ...), or
// PATH unchanged.
std::string mapSetPrefixOf(const std::string& path);

}  // namespace octo_slice_mapper
