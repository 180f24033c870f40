#include "octo_slice_mapper/map_io.h"

#include "core/internal/rgb_png.h"
#include "octo_slice_mapper/internal/height_map.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <png.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <sstream>
#include <utility>
#include <vector>

#include "octo_slice_mapper/internal/atomic_file.h"

namespace octo_slice_mapper {
namespace {

const char kBinaryHeader[] = "# Octomap OcTree binary file";
const char kFullHeader[] = "# Octomap OcTree file";

// Walks the node records of a map file's data from `begin`, depth first as OctoMap's readers
// read them, without building anything: every record must be complete, and only records at
// depth <= `deepest_parent` may have child records (an OcTree has 16 levels). `record(bytes, n,
// why)` looks at record n (`size` bytes) and returns how many of its children have records of
// their own, or -1 with the reason. False with the reason on the first problem.
template <typename Record>
bool walkRecords(const std::string& bytes, std::size_t begin, std::size_t size, std::size_t deepest_parent,
                 Record&& record, std::string* why) {
  std::size_t pos = begin, n = 0;
  std::vector<int> left;  // per open level, the child records still to read
  do {
    if (!left.empty()) --left.back();
    if (pos + size > bytes.size()) {
      *why = "the data ends inside node record " + std::to_string(n + 1);
      return false;
    }
    const int children = record(reinterpret_cast<const unsigned char*>(bytes.data() + pos), ++n, why);
    pos += size;
    if (children < 0) return false;
    if (children > 0) {
      if (left.size() > deepest_parent) {
        *why = "node record " + std::to_string(n) + " has children below the deepest level";
        return false;
      }
      left.push_back(children);
    }
    while (!left.empty() && left.back() == 0) left.pop_back();
  } while (!left.empty());
  return true;
}

// A .ot's data: each node is its float log-odds, then a byte of child bits; every value must be
// a finite log-odds. Counts the nodes.
bool walkFullTreeData(const std::string& bytes, std::size_t begin, std::size_t* nodes, std::string* why) {
  *nodes = 0;
  return walkRecords(bytes, begin, sizeof(float) + 1, 15,
                     [nodes](const unsigned char* r, std::size_t n, std::string* reason) {
                       float value;
                       std::memcpy(&value, r, sizeof value);
                       ++*nodes;
                       if (!std::isfinite(value)) {
                         *reason = "node " + std::to_string(n) + "'s log-odds is not a finite number";
                         return -1;
                       }
                       return __builtin_popcount(r[sizeof(float)]);
                     },
                     why);
}

// A .bt's data: each node is two bytes of 2-bit child codes (01 free leaf, 10 occupied leaf, 11 a
// child whose own record follows, 00 none). Counts the nodes (the root and every coded child).
bool walkBinaryTreeData(const std::string& bytes, std::size_t begin, std::size_t* nodes, std::string* why) {
  *nodes = 1;
  return walkRecords(bytes, begin, 2, 14,
                     [nodes](const unsigned char* r, std::size_t, std::string*) {
                       const unsigned codes = r[0] | (unsigned(r[1]) << 8);
                       int inner = 0;
                       for (int i = 0; i < 8; ++i) {
                         const unsigned code = (codes >> (2 * i)) & 3u;
                         *nodes += code != 0;
                         inner += code == 3;
                       }
                       return inner;
                     },
                     why);
}

// The header's node count and where the data begins (after its "data" line), for .bt and .ot.
bool headerOf(const std::string& bytes, std::size_t* declared, std::size_t* data_begin) {
  const std::size_t size_at = bytes.find("\nsize ");
  const std::size_t data_at = bytes.find("\ndata\n");
  if (size_at == std::string::npos || size_at > 512 || data_at == std::string::npos || data_at > 512) return false;
  *data_begin = data_at + 6;
  return std::sscanf(bytes.c_str() + size_at + 6, "%zu", declared) == 1;
}
const int kMinPictureSide = 1600;  // pixels: thin walls of big maps stay visible

bool startsWith(const std::string& s, const char* prefix) { return s.compare(0, std::strlen(prefix), prefix) == 0; }

std::string baseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string dirName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}


}  // namespace

bool addBinaryTree(const octomap::OcTree& tree, const std::string& path, FileSet* files, std::string* error) {
  std::ostringstream out(std::ios::binary);
  if (!tree.writeBinaryConst(out)) {
    *error = "octomap could not serialise the tree for " + path;
    return false;
  }
  files->emplace_back(path, out.str());
  return true;
}

std::vector<OccupiedVoxel> occupiedVoxels(const octomap::OcTree& tree) {
  std::vector<OccupiedVoxel> voxels;
  const unsigned depth = tree.getTreeDepth();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const float probability = static_cast<float>(it->getOccupancy());
    // A node `level` levels above the leaves holds 2^level leaves per axis around its key.
    const unsigned level = depth - it.getDepth();
    const octomap::OcTreeKey key = it.getKey();
    const unsigned span = 1u << level, half = level ? span / 2 : 0;
    for (unsigned i = 0; i < span; ++i) {
      for (unsigned j = 0; j < span; ++j) {
        for (unsigned k = 0; k < span; ++k) {
          const octomap::OcTreeKey leaf(static_cast<octomap::key_type>(key[0] - half + i),
                                        static_cast<octomap::key_type>(key[1] - half + j),
                                        static_cast<octomap::key_type>(key[2] - half + k));
          voxels.push_back({static_cast<float>(tree.keyToCoord(leaf[0])), static_cast<float>(tree.keyToCoord(leaf[1])),
                            static_cast<float>(tree.keyToCoord(leaf[2])), probability});
        }
      }
    }
  }
  return voxels;
}

void fourFloatCloud(const void* data, std::size_t points, const std::array<const char*, 4>& names,
                    pcl::PCLPointCloud2* cloud) {
  *cloud = pcl::PCLPointCloud2();
  cloud->width = static_cast<std::uint32_t>(points);
  cloud->height = 1;
  cloud->is_dense = true;
  cloud->point_step = 4 * sizeof(float);
  cloud->row_step = cloud->point_step * cloud->width;
  for (std::uint32_t f = 0; f < 4; ++f) {
    pcl::PCLPointField field;
    field.name = names[f];
    field.offset = 4 * f;
    field.datatype = pcl::PCLPointField::FLOAT32;
    field.count = 1;
    cloud->fields.push_back(field);
  }
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  cloud->data.assign(bytes, bytes + points * cloud->point_step);
}

void occupiedVoxelsCloud(const std::vector<OccupiedVoxel>& voxels, pcl::PCLPointCloud2* cloud) {
  static_assert(sizeof(OccupiedVoxel) == 16, "four packed floats, as the fields declare");
  fourFloatCloud(voxels.data(), voxels.size(), {"x", "y", "z", "occupancy"}, cloud);
}

bool addPointCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& path, FileSet* files,
                   std::string* error) {
  pcl::PCLPointCloud2 cloud;
  occupiedVoxelsCloud(voxels, &cloud);
  // PCL's own header; the data follow it as PCDWriter::writeBinary puts them (the points packed).
  pcl::PCDWriter writer;
  std::string bytes;
  try {
    bytes = writer.generateHeaderBinary(cloud, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity());
  } catch (const std::exception& e) {
    *error = "PCL could not write the header of " + path + ": " + e.what();
    return false;
  }
  if (bytes.empty() || bytes[0] != '#') {  // the save id goes after the first line, a comment
    *error = "PCL wrote an unexpected header for " + path;
    return false;
  }
  bytes += "DATA binary\n";  // as PCDWriter::writeBinary ends the header
  bytes.append(reinterpret_cast<const char*>(cloud.data.data()), cloud.data.size());
  files->emplace_back(path, std::move(bytes));
  return true;
}

bool savePointCloud(const std::vector<OccupiedVoxel>& voxels, const std::string& path, std::string* error) {
  FileSet files;
  return addPointCloud(voxels, path, &files, error) && writeFilesAtomically(files, nullptr, error);
}

bool addFullTree(const octomap::OcTree& tree, const std::string& path, FileSet* files, std::string* error) {
  std::ostringstream out(std::ios::binary);
  if (!tree.write(out)) {
    *error = "octomap could not serialise the tree for " + path;
    return false;
  }
  files->emplace_back(path, out.str());
  return true;
}

bool saveBinaryTree(const octomap::OcTree& tree, const std::string& path, std::string* error) {
  FileSet files;
  return addBinaryTree(tree, path, &files, error) && writeFilesAtomically(files, nullptr, error);
}

bool saveFullTree(const octomap::OcTree& tree, const std::string& path, std::string* error) {
  FileSet files;
  return addFullTree(tree, path, &files, error) && writeFilesAtomically(files, nullptr, error);
}

std::unique_ptr<octomap::OcTree> loadTree(const std::string& path, std::string* error) {
  std::string bytes;
  if (!readFile(path, &bytes, error)) return nullptr;
  std::istringstream in(bytes, std::ios::binary);
  if (startsWith(bytes, kBinaryHeader)) {
    // OctoMap's reader reads child bytes past the end of a truncated file (uninitialised, so it
    // can recurse without bound): the data is walked here first.
    std::size_t declared = 0, data_begin = 0, nodes = 0;
    std::string why;
    if (!headerOf(bytes, &declared, &data_begin) || !walkBinaryTreeData(bytes, data_begin, &nodes, &why) ||
        nodes != declared) {
      *error = path + ": corrupt or truncated OctoMap binary (.bt) file" + (why.empty() ? "" : ": " + why);
      return nullptr;
    }
    auto tree = std::make_unique<octomap::OcTree>(0.1);
    if (!tree->readBinary(in)) {
      *error = path + ": corrupt or truncated OctoMap binary (.bt) file";
      return nullptr;
    }
    return tree;
  }
  if (startsWith(bytes, kFullHeader)) {
    // OctoMap's reader builds a tree from whatever a truncated or damaged file holds (half of an
    // .ot can give billions of known cells and voxels hundreds of metres up), and a child byte it reads past the
    // end is uninitialised, so it can recurse without bound: the data is walked here first.
    std::size_t declared = 0, data_begin = 0;
    if (!headerOf(bytes, &declared, &data_begin)) {
      *error = path + ": corrupt OctoMap (.ot) file: no node count or no data in its header";
      return nullptr;
    }
    std::size_t nodes = 0;
    std::string why;
    if (!walkFullTreeData(bytes, data_begin, &nodes, &why) || nodes != declared) {
      *error = path + ": truncated or corrupt OctoMap (.ot) file: " +
               (why.empty() ? std::to_string(declared) + " nodes declared, " + std::to_string(nodes) + " there" : why);
      return nullptr;
    }
    std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(in));
    if (!abstract) {
      *error = path + ": corrupt or truncated OctoMap (.ot) file";
      return nullptr;
    }
    auto* tree = dynamic_cast<octomap::OcTree*>(abstract.get());
    if (!tree) {
      *error = path + ": holds a " + abstract->getTreeType() + ", not an OcTree";
      return nullptr;
    }
    if (in.fail() || tree->size() != declared) {
      *error = path + ": corrupt OctoMap (.ot) file: " + std::to_string(declared) + " nodes declared, " +
               std::to_string(tree->size()) + " read";
      return nullptr;
    }
    abstract.release();
    return std::unique_ptr<octomap::OcTree>(tree);
  }
  *error = path + ": not an OctoMap file (neither .bt nor .ot header)";
  return nullptr;
}

GridImage cropToKnown(const GridImage& full, int margin_cells) {
  GridImage grid;
  grid.resolution = full.resolution;
  int i0 = full.width, j0 = full.height, i1 = -1, j1 = -1;
  for (int j = 0; j < full.height; ++j) {
    for (int i = 0; i < full.width; ++i) {
      if (full.at(i, j) == kUnknownCell) continue;
      i0 = std::min(i0, i), i1 = std::max(i1, i), j0 = std::min(j0, j), j1 = std::max(j1, j);
    }
  }
  if (i1 < 0) return grid;
  i0 = std::max(0, i0 - margin_cells), j0 = std::max(0, j0 - margin_cells);
  i1 = std::min(full.width - 1, i1 + margin_cells), j1 = std::min(full.height - 1, j1 + margin_cells);
  grid.width = i1 - i0 + 1;
  grid.height = j1 - j0 + 1;
  grid.origin_x = full.origin_x + i0 * grid.resolution;
  grid.origin_y = full.origin_y + j0 * grid.resolution;
  grid.cells.reserve(std::size_t(grid.width) * grid.height);
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) grid.cells.push_back(full.at(i, j));
  }
  return grid;
}

GridImage gridImageOf(const SliceGrid& slice, int margin_cells) {
  // The live grid keeps spare room to grow into: crop it to what is known.
  GridImage full;
  full.resolution = slice.resolution();
  full.width = slice.width();
  full.height = slice.height();
  full.origin_x = slice.width() ? slice.originX() : 0.0;
  full.origin_y = slice.height() ? slice.originY() : 0.0;
  full.cells = slice.data();
  return cropToKnown(full, margin_cells);
}

GridImage inFrameOf(const GridImage& grid, const GridImage& frame) {
  const double res = frame.resolution;
  if (frame.width <= 0 || frame.height <= 0 || std::abs(grid.resolution - res) > 1e-9 * res) return grid;
  // Whole cells between the two origins: both grids come from the same octree's voxel columns.
  const int di = static_cast<int>(std::lround((grid.origin_x - frame.origin_x) / res));
  const int dj = static_cast<int>(std::lround((grid.origin_y - frame.origin_y) / res));
  int i0 = 0, j0 = 0, i1 = frame.width - 1, j1 = frame.height - 1;
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      if (grid.at(i, j) == kUnknownCell) continue;
      i0 = std::min(i0, i + di), i1 = std::max(i1, i + di), j0 = std::min(j0, j + dj), j1 = std::max(j1, j + dj);
    }
  }
  GridImage out;
  out.resolution = res;
  out.width = i1 - i0 + 1;
  out.height = j1 - j0 + 1;
  out.origin_x = frame.origin_x + i0 * res;
  out.origin_y = frame.origin_y + j0 * res;
  out.cells.assign(std::size_t(out.width) * out.height, kUnknownCell);
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const std::int8_t v = grid.at(i, j);
      if (v != kUnknownCell) out.cells[std::size_t(j + dj - j0) * out.width + (i + di - i0)] = v;
    }
  }
  return out;
}

bool addPgmYaml(const GridImage& grid, const std::string& prefix, FileSet* files, std::string* error,
                const PgmOptions& options) {
  if (grid.width <= 0 || grid.height <= 0) {
    *error = "the map is empty: nothing to write to " + prefix + ".pgm";
    return false;
  }
  std::ostringstream pgm(std::ios::binary);
  pgm << "P5\n# octo_slice_mapper " << grid.resolution << " m/pix\n" << grid.width << ' ' << grid.height << "\n255\n";
  std::string row(static_cast<std::size_t>(grid.width), '\0');
  for (int j = grid.height - 1; j >= 0; --j) {  // pgm rows go top-down
    for (int i = 0; i < grid.width; ++i) {
      const int v = grid.at(i, j);
      unsigned char pixel = 205;
      if (v >= 0 && v / 100.0 > options.occupied_thresh) pixel = 0;
      else if (v >= 0 && v / 100.0 < options.free_thresh) pixel = 254;
      row[static_cast<std::size_t>(i)] = static_cast<char>(pixel);
    }
    pgm << row;
  }
  std::ostringstream yaml;
  yaml.precision(9);
  yaml << "image: " << baseName(prefix) << ".pgm\n"
       << "resolution: " << grid.resolution << "\n"
       << "origin: [" << grid.origin_x << ", " << grid.origin_y << ", 0.0]\n"
       << "negate: 0\n"
       << "occupied_thresh: " << options.occupied_thresh << "\n"
       << "free_thresh: " << options.free_thresh << "\n";
  // The image first (files are renamed in order): a yaml never names a pgm that is not there.
  files->emplace_back(prefix + ".pgm", pgm.str());
  files->emplace_back(prefix + ".yaml", yaml.str());
  return true;
}

bool savePgmYaml(const GridImage& grid, const std::string& prefix, std::string* error, const PgmOptions& options) {
  FileSet files;
  return addPgmYaml(grid, prefix, &files, error, options) && writeFilesAtomically(files, nullptr, error);
}

bool loadPgmYaml(const std::string& yaml_path, GridImage* grid, std::string* error) {
  std::string text;
  if (!readFile(yaml_path, &text, error)) return false;
  std::string image;
  double occupied_thresh = 0.65, free_thresh = 0.196;
  int negate = 0;
  bool have_res = false, have_origin = false;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    std::string value = line.substr(colon + 1);
    value.erase(0, value.find_first_not_of(" \t"));
    if (key == "image") image = value;
    else if (key == "resolution") have_res = std::sscanf(value.c_str(), "%lf", &grid->resolution) == 1;
    else if (key == "origin") have_origin = std::sscanf(value.c_str(), "[%lf , %lf", &grid->origin_x, &grid->origin_y) == 2;
    else if (key == "occupied_thresh") std::sscanf(value.c_str(), "%lf", &occupied_thresh);
    else if (key == "free_thresh") std::sscanf(value.c_str(), "%lf", &free_thresh);
    else if (key == "negate") std::sscanf(value.c_str(), "%d", &negate);
  }
  if (image.empty() || !have_res || !have_origin || !(grid->resolution > 0)) {
    *error = yaml_path + ": needs image, resolution > 0 and origin";
    return false;
  }
  const std::string image_path = image[0] == '/' ? image : dirName(yaml_path) + "/" + image;
  std::string pgm;
  if (!readFile(image_path, &pgm, error)) return false;
  std::istringstream in(pgm, std::ios::binary);
  std::string magic;
  in >> magic;
  auto skipComments = [&in]() {
    in >> std::ws;
    while (in.peek() == '#') {
      std::string ignored;
      std::getline(in, ignored);
      in >> std::ws;
    }
  };
  int maxval = 0;
  skipComments();
  in >> grid->width;
  skipComments();
  in >> grid->height;
  skipComments();
  in >> maxval;
  in.get();
  const std::size_t n = std::size_t(std::max(grid->width, 0)) * std::size_t(std::max(grid->height, 0));
  if (magic != "P5" || !in || grid->width <= 0 || grid->height <= 0 || maxval != 255 ||
      pgm.size() - static_cast<std::size_t>(in.tellg()) < n) {
    *error = image_path + ": not a complete 8-bit binary PGM (P5)";
    return false;
  }
  const auto* pixels = reinterpret_cast<const unsigned char*>(pgm.data() + static_cast<std::size_t>(in.tellg()));
  grid->cells.assign(n, kUnknownCell);
  for (int row = 0; row < grid->height; ++row) {
    const int j = grid->height - 1 - row;
    for (int i = 0; i < grid->width; ++i) {
      const unsigned char v = pixels[std::size_t(row) * grid->width + i];
      const double p = negate ? v / 255.0 : (255 - v) / 255.0;
      std::int8_t cell = kUnknownCell;
      if (p > occupied_thresh) cell = 100;
      else if (p < free_thresh) cell = 0;
      grid->cells[std::size_t(j) * grid->width + i] = cell;
    }
  }
  return true;
}

bool addPng(const GridImage& grid, const std::string& path, FileSet* files, std::string* error) {
  if (grid.width <= 0 || grid.height <= 0) {
    *error = "the map is empty: nothing to draw into " + path;
    return false;
  }
  // Whole pixels per cell, so that a small map is still readable.
  const int scale = std::max(1, (kMinPictureSide + std::max(grid.width, grid.height) - 1) / std::max(grid.width, grid.height));
  const int out_w = grid.width * scale, out_h = grid.height * scale;
  std::string bytes, reason;
  // Each cell's row of pixels is drawn once and copied to the `scale` rows it covers.
  std::vector<std::uint8_t> drawn(std::size_t(out_w) * 3);
  int drawn_j = -1;
  const bool encoded = encodeRgbPng(out_w, out_h, [&](int y, std::uint8_t* row) {
    const int j = grid.height - 1 - y / scale;  // north up
    if (j != drawn_j) {
      for (int i = 0; i < out_w; ++i) {
        const int v = grid.at(i / scale, j);
        std::uint8_t* px = &drawn[std::size_t(i) * 3];
        if (v < 0) {
          px[0] = 196, px[1] = 204, px[2] = 216;
        } else {
          const auto grey = static_cast<std::uint8_t>(std::lround(255.0 * (1.0 - v / 100.0)));
          px[0] = px[1] = px[2] = grey;
        }
      }
      drawn_j = j;
    }
    std::copy(drawn.begin(), drawn.end(), row);
  }, &bytes, &reason);
  if (!encoded) {
    *error = reason + " while encoding " + path;
    return false;
  }
  files->emplace_back(path, std::move(bytes));
  return true;
}

bool savePng(const GridImage& grid, const std::string& path, std::string* error) {
  FileSet files;
  return addPng(grid, path, &files, error) && writeFilesAtomically(files, nullptr, error);
}

namespace {

// The endings of a set's files; mapSetPrefixOf tries them from the last (the longest) on.
const char* const kSetExtensions[] = {".bt", ".ot", ".pcd", ".pgm", ".yaml", ".png", "_incremental.pgm", "_incremental.yaml",
                                      "_incremental.png"};
const char kSaveIdTag[] = "save_id";
constexpr std::size_t kSaveIdLength = 16;  // hex digits of a 64-bit hash
constexpr std::size_t kSaveIdSearch = 1024;  // every format puts it within its first bytes

bool endsWith(const std::string& s, const char* suffix) {
  const std::size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

// A set's id: FNV-1a over all its files' bytes but the .yaml's first line (the .pgm's name), so
// the same map saved twice, under any name, gets the same id (saves stay reproducible byte for
// byte) and two different sets almost surely differ.
std::string saveIdOf(const FileSet& files) {
  std::uint64_t h = 1469598103934665603ull;
  for (const auto& file : files) {
    const std::size_t from = endsWith(file.first, ".yaml") ? file.second.find('\n') + 1 : 0;
    for (std::size_t k = from; k < file.second.size(); ++k) {
      h = (h ^ static_cast<unsigned char>(file.second[k])) * 1099511628211ull;
    }
  }
  char hex[kSaveIdLength + 1];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

void putBigEndian32(std::string* out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<char>((v >> shift) & 0xFF));
}

// Writes the id where each format has room for a note its readers skip: a comment line after the
// first line of .bt, .ot (OctoMap's readers skip '#' lines of the header) and .pgm, a key of
// the .yaml (map_server reads only the keys it knows), a tEXt chunk after the .png's IHDR.
void stampSaveId(std::pair<std::string, std::string>* file, const std::string& id) {
  std::string& bytes = file->second;
  if (endsWith(file->first, ".yaml")) {
    bytes += std::string(kSaveIdTag) + ": " + id + "\n";
  } else if (endsWith(file->first, ".png")) {
    constexpr std::size_t kAfterHeader = 8 + 4 + 4 + 13 + 4;  // signature, then IHDR's length, type, data, CRC
    std::string type_and_data = std::string("tEXt") + kSaveIdTag + '\0' + id;
    std::string chunk;
    putBigEndian32(&chunk, static_cast<std::uint32_t>(type_and_data.size() - 4));
    chunk += type_and_data;
    putBigEndian32(&chunk, static_cast<std::uint32_t>(
                               crc32(0, reinterpret_cast<const Bytef*>(type_and_data.data()), type_and_data.size())));
    bytes.insert(kAfterHeader, chunk);
  } else {
    bytes.insert(bytes.find('\n') + 1, "# " + std::string(kSaveIdTag) + " " + id + "\n");
  }
}

bool sameGrid(const GridImage& a, const GridImage& b) {
  return &a == &b || (a.width == b.width && a.height == b.height && a.resolution == b.resolution &&
                      a.origin_x == b.origin_x && a.origin_y == b.origin_y && a.cells == b.cells);
}

}  // namespace

bool saveMapSet(const octomap::OcTree& tree, const GridImage& grid, const std::string& prefix,
                std::vector<std::string>* written, std::string* error, const GridImage* incremental,
                const HeightMap* heights) {
  FileSet files;
  if (!addBinaryTree(tree, prefix + ".bt", &files, error) || !addFullTree(tree, prefix + ".ot", &files, error) ||
      !addPointCloud(occupiedVoxels(tree), prefix + ".pcd", &files, error) ||
      !addPgmYaml(grid, prefix, &files, error) || !addPng(grid, prefix + ".png", &files, error)) {
    return false;
  }
  const std::size_t picture = files.size() - 1;
  const std::string base = prefix + "_incremental";
  if (incremental) {
    if (!addPgmYaml(*incremental, base, &files, error)) return false;
    // Where no pass changed the map (none ran: --no-optimize, or clouds only, which keep no
    // scans), its picture is the map's: encoded once (the pictures take most of a save's time).
    if (sameGrid(*incremental, grid)) {
      files.emplace_back(base + ".png", files[picture].second);
    } else if (!addPng(*incremental, base + ".png", &files, error)) {
      return false;
    }
  }
  if (heights && !addHeightMap(*heights, prefix, &files, error)) return false;
  const std::string id = saveIdOf(files);
  for (auto& file : files) {
    if (!endsWith(file.first, ".bin")) stampSaveId(&file, id);  // raw floats: no room for a note
  }
  return writeFilesAtomically(files, written, error);
}

std::string readSaveId(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return "";
  std::string head(kSaveIdSearch, '\0');
  head.resize(std::fread(&head[0], 1, head.size(), f));
  std::fclose(f);
  std::size_t at = head.find(kSaveIdTag);
  if (at == std::string::npos) return "";
  at += sizeof(kSaveIdTag) - 1;
  while (at < head.size() && (head[at] == ' ' || head[at] == ':' || head[at] == '\0')) ++at;
  std::string id = head.substr(at, kSaveIdLength);
  const bool hex = id.size() == kSaveIdLength &&
                   std::all_of(id.begin(), id.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
  return hex ? id : "";
}

bool MapSetCheck::mixed() const {
  for (const auto& file : files) {
    if (file.second != files.front().second) return true;
  }
  return false;
}

std::string MapSetCheck::describe() const {
  std::vector<std::pair<std::string, std::string>> groups;  // (save id, files)
  for (const auto& file : files) {
    auto group = std::find_if(groups.begin(), groups.end(), [&](const auto& g) { return g.first == file.second; });
    if (group == groups.end()) group = groups.insert(groups.end(), {file.second, ""});
    group->second += (group->second.empty() ? "" : " ") + baseName(file.first);
  }
  std::string text;
  for (const auto& group : groups) {
    text += (text.empty() ? "" : "; ") + group.second + " " +
            (group.first.empty() ? "carry no save id" : "are from save " + group.first);
  }
  return text;
}

std::string mapSetPrefixOf(const std::string& path) {
  for (auto it = std::rbegin(kSetExtensions); it != std::rend(kSetExtensions); ++it) {
    if (endsWith(path, *it)) return path.substr(0, path.size() - std::strlen(*it));
  }
  return path;
}

MapSetCheck checkMapSet(const std::string& prefix) {
  MapSetCheck check;
  for (const char* extension : kSetExtensions) {
    const std::string path = prefix + extension;
    if (::access(path.c_str(), F_OK) == 0) check.files.emplace_back(path, readSaveId(path));
  }
  return check;
}

}  // namespace octo_slice_mapper
