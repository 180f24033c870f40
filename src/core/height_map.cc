#include "octo_slice_mapper/internal/height_map.h"

#include "core/internal/rgb_png.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>

namespace octo_slice_mapper {

namespace {

// The heights on `map`'s raster (its geometry set, its grids empty).
void fillHeights(const std::vector<OccupiedVoxel>& voxels, const FloorLayer& floor, double resolution,
                 double min_height, HeightMap* map) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  map->floor.assign(std::size_t(map->width) * map->height, nan);
  map->top.assign(map->floor.size(), nan);
  const auto cellOf = [&](double x, double y, std::size_t* index) {
    const int i = int(std::floor((x - map->origin_x) / map->resolution));
    const int j = int(std::floor((y - map->origin_y) / map->resolution));
    if (i < 0 || j < 0 || i >= map->width || j >= map->height) return false;
    *index = std::size_t(j) * map->width + i;
    return true;
  };
  floor.forEachCell([&](std::uint16_t kx, std::uint16_t ky, float h) {
    std::size_t index;
    if (cellOf(floorCentreOf(kx, resolution), floorCentreOf(ky, resolution), &index)) map->floor[index] = h;
  });
  const float fallback = static_cast<float>(floor.fallbackHeight());
  for (const OccupiedVoxel& v : voxels) {
    std::size_t index;
    if (!cellOf(v.x, v.y, &index)) continue;
    const float under = std::isnan(map->floor[index]) ? fallback : map->floor[index];
    if (v.z - under < float(min_height)) continue;  // the voxel's centre: the floor's own voxels
    const float top = v.z + 0.5f * float(resolution) - under;
    if (std::isnan(map->top[index]) || top > map->top[index]) map->top[index] = top;
  }
}

}  // namespace

HeightMap heightMapOf(const octomap::OcTree& tree, const FloorLayer& floor, const GridImage& frame, double min_height) {
  HeightMap map;
  if (frame.width <= 0 || frame.height <= 0 || floor.status().cells == 0) return map;
  map.width = frame.width, map.height = frame.height;
  map.resolution = frame.resolution, map.origin_x = frame.origin_x, map.origin_y = frame.origin_y;
  map.fallback_floor = floor.fallbackHeight();
  fillHeights(occupiedVoxels(tree), floor, tree.getResolution(), min_height, &map);
  return map;
}

HeightMap heightMapOf(const std::vector<OccupiedVoxel>& voxels, const FloorLayer& floor, double resolution,
                      double min_height) {
  HeightMap map;
  if (floor.status().cells == 0) return map;
  // The keys' box of the floor's cells and the voxels.
  int x0 = 1 << 30, y0 = 1 << 30, x1 = -(1 << 30), y1 = -(1 << 30);
  const auto add = [&](int kx, int ky) {
    x0 = std::min(x0, kx), y0 = std::min(y0, ky), x1 = std::max(x1, kx), y1 = std::max(y1, ky);
  };
  floor.forEachCell([&](std::uint16_t kx, std::uint16_t ky, float) { add(kx, ky); });
  for (const OccupiedVoxel& v : voxels) add(floorKeyOf(v.x, resolution), floorKeyOf(v.y, resolution));
  if (x1 < x0 || y1 < y0) return map;
  map.width = x1 - x0 + 1, map.height = y1 - y0 + 1;
  map.resolution = resolution;
  map.origin_x = (x0 - 32768) * resolution, map.origin_y = (y0 - 32768) * resolution;
  map.fallback_floor = floor.fallbackHeight();
  fillHeights(voxels, floor, resolution, min_height, &map);
  return map;
}


namespace {

// A 3 x 5 pixel font for the legend's numbers: each glyph's rows, the top row first, 3 bits each.
const unsigned char* glyph(char c) {
  static const unsigned char digits[10][5] = {{7, 5, 5, 5, 7}, {2, 6, 2, 2, 7}, {7, 1, 7, 4, 7}, {7, 1, 7, 1, 7},
                                              {5, 5, 7, 1, 1}, {7, 4, 7, 1, 7}, {7, 4, 7, 5, 7}, {7, 1, 1, 1, 1},
                                              {7, 5, 7, 5, 7}, {7, 5, 7, 1, 7}};
  static const unsigned char dot[5] = {0, 0, 0, 0, 2}, m[5] = {0, 0, 7, 7, 5}, space[5] = {0, 0, 0, 0, 0};
  if (c >= '0' && c <= '9') return digits[c - '0'];
  if (c == '.') return dot;
  if (c == 'm') return m;
  return space;
}

struct Rgb {  // three bytes, as a PNG row holds them
  std::uint8_t r, g, b;
};
static_assert(sizeof(Rgb) == 3, "rows are copied as they are");

// Dark blue (low) through green and yellow to red (2 m and above).
Rgb colourOf(double t) {
  t = std::clamp(t, 0.0, 1.0);
  const double stops[5][3] = {{40, 40, 150}, {30, 140, 200}, {60, 180, 80}, {240, 210, 40}, {210, 40, 30}};
  const double x = t * 4.0;
  const int k = std::min(3, int(x));
  const double f = x - k;
  const auto mix = [&](int c) { return static_cast<std::uint8_t>(std::lround(stops[k][c] * (1 - f) + stops[k + 1][c] * f)); };
  return {mix(0), mix(1), mix(2)};
}

}  // namespace

bool addHeightMap(const HeightMap& map, const std::string& prefix, FileSet* files, std::string* error) {
  if (map.empty()) return true;
  constexpr double kTopOfScale = 2.0;  // m above the floor: red
  const std::string name = prefix + "_heights";
  std::ostringstream yaml;
  // The file's name first: a set's save id leaves the .yaml files' first lines out, so that the
  // same map saved under another name keeps its id.
  yaml << "data: " << name.substr(name.find_last_of('/') + 1) << ".bin\n"
       << "# The floor found under each cell and the top of what stands on it (octo_slice_mapper).\n"
       << "format: float32 little-endian, the floor grid then the top grid, row by row from the bottom row\n"
       << "floor: height of the floor found (m, map frame); NaN where none was found\n"
       << "top: height above that floor of the top of the highest occupied voxel (m); NaN where none\n"
       << "resolution: " << map.resolution << "\n"
       << "origin: [" << map.origin_x << ", " << map.origin_y << "]\n"
       << "width: " << map.width << "\nheight: " << map.height << "\n";
  if (std::isfinite(map.fallback_floor)) {
    yaml << "# fallback_floor: the floor's height where no cell's is known (m, map frame)\n"
         << "fallback_floor: " << std::setprecision(9) << map.fallback_floor << "\n";
  }
  files->emplace_back(name + ".yaml", yaml.str());
  std::string data;
  data.resize((map.floor.size() + map.top.size()) * sizeof(float));
  std::memcpy(&data[0], map.floor.data(), map.floor.size() * sizeof(float));  // x86-64: little-endian
  std::memcpy(&data[map.floor.size() * sizeof(float)], map.top.data(), map.top.size() * sizeof(float));
  files->emplace_back(name + ".bin", std::move(data));

  // The picture: each cell 2-8 pixels (a small map about 600 px wide), a legend strip below it.
  const int scale = std::clamp(600 / std::max(1, map.width), 2, 8);
  const int width = std::max(map.width * scale, 220), legend = 40, height = map.height * scale + legend;
  std::vector<Rgb> image(std::size_t(width) * height, Rgb{205, 205, 215});  // unknown: blue-grey
  for (int j = 0; j < map.height; ++j) {
    for (int i = 0; i < map.width; ++i) {
      const std::size_t c = std::size_t(j) * map.width + i;
      Rgb px;
      if (!std::isnan(map.top[c])) px = colourOf(map.top[c] / kTopOfScale);
      else if (!std::isnan(map.floor[c])) px = {245, 245, 245};
      else continue;
      for (int dy = 0; dy < scale; ++dy) {
        for (int dx = 0; dx < scale; ++dx) {
          image[std::size_t((map.height - 1 - j) * scale + dy) * width + i * scale + dx] = px;  // row 0 at the top
        }
      }
    }
  }
  // Legend: the scale from 0 to 2 m, ticks and numbers every 0.5 m.
  const int y0 = map.height * scale + 6, bar_x0 = 10, bar_w = 200;
  for (int y = y0; y < height; ++y) {
    for (int x = 0; x < width; ++x) image[std::size_t(y) * width + x] = {255, 255, 255};
  }
  for (int x = 0; x < bar_w; ++x) {
    for (int y = y0; y < y0 + 12; ++y) image[std::size_t(y) * width + bar_x0 + x] = colourOf(double(x) / (bar_w - 1));
  }
  const auto text = [&](int x, int y, const std::string& s) {
    for (char ch : s) {
      const unsigned char* g = glyph(ch);
      for (int r = 0; r < 5; ++r) {
        for (int b = 0; b < 3; ++b) {
          if (!(g[r] >> (2 - b) & 1)) continue;
          for (int dy = 0; dy < 2; ++dy) {
            for (int dx = 0; dx < 2; ++dx) {
              const int px = x + b * 2 + dx, py = y + r * 2 + dy;
              if (px >= 0 && px < width && py >= 0 && py < height) image[std::size_t(py) * width + px] = {0, 0, 0};
            }
          }
        }
      }
      x += 8;
    }
  };
  for (int k = 0; k <= 4; ++k) {
    const int x = bar_x0 + k * (bar_w - 1) / 4;
    for (int y = y0 + 12; y < y0 + 16; ++y) image[std::size_t(y) * width + x] = {0, 0, 0};
    const std::string label = k == 0 ? "0" : k == 1 ? "0.5" : k == 2 ? "1" : k == 3 ? "1.5" : "2m";
    text(x - 3, y0 + 18, label);
  }

  std::string bytes, reason;
  const bool encoded = encodeRgbPng(width, height, [&](int y, std::uint8_t* row) {
    std::memcpy(row, &image[std::size_t(y) * width], std::size_t(width) * sizeof(Rgb));
  }, &bytes, &reason);
  if (!encoded) {
    *error = name + ".png: " + reason;
    return false;
  }
  files->emplace_back(name + ".png", std::move(bytes));
  return true;
}

bool readHeightMap(const std::string& yaml_path, HeightMap* map, std::string* error) {
  std::ifstream yaml(yaml_path);
  if (!yaml) {
    *error = yaml_path + ": cannot open";
    return false;
  }
  std::map<std::string, std::string> keys;
  std::string line;
  while (std::getline(yaml, line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::size_t from = colon + 1;
    while (from < line.size() && line[from] == ' ') ++from;
    keys[line.substr(0, colon)] = line.substr(from);
  }
  const auto number = [&](const char* key, double* value) {
    const auto it = keys.find(key);
    char* end = nullptr;
    if (it != keys.end()) *value = std::strtod(it->second.c_str(), &end);
    if (it == keys.end() || end == it->second.c_str() || *end != '\0') {
      *error = yaml_path + ": no number '" + key + "'";
      return false;
    }
    return true;
  };
  HeightMap read;
  double width = 0, height = 0;
  if (!number("resolution", &read.resolution) || !number("width", &width) || !number("height", &height)) return false;
  if (keys.count("fallback_floor") && !number("fallback_floor", &read.fallback_floor)) return false;
  const auto origin = keys.find("origin");
  if (origin == keys.end() ||
      std::sscanf(origin->second.c_str(), "[%lf, %lf]", &read.origin_x, &read.origin_y) != 2) {
    *error = yaml_path + ": no 'origin: [x, y]'";
    return false;
  }
  if (!(read.resolution > 0.0) || !(width >= 1 && width <= 1e6 && height >= 1 && height <= 1e6) ||
      width != std::floor(width) || height != std::floor(height) || !keys.count("data")) {
    *error = yaml_path + ": no data file, or its geometry is impossible";
    return false;
  }
  read.width = int(width), read.height = int(height);
  const std::string data_path = yaml_path.substr(0, yaml_path.find_last_of('/') + 1) + keys["data"];
  std::ifstream data(data_path, std::ios::binary);
  if (!data) {
    *error = data_path + ": cannot open (named by " + yaml_path + ")";
    return false;
  }
  const std::size_t cells = std::size_t(read.width) * std::size_t(read.height);
  std::string bytes((std::istreambuf_iterator<char>(data)), std::istreambuf_iterator<char>());
  if (bytes.size() != 2 * cells * sizeof(float)) {
    *error = data_path + ": " + std::to_string(bytes.size()) + " bytes, not the " +
             std::to_string(2 * cells * sizeof(float)) + " of two " + std::to_string(read.width) + " x " +
             std::to_string(read.height) + " float grids";
    return false;
  }
  read.floor.resize(cells);
  read.top.resize(cells);
  std::memcpy(read.floor.data(), bytes.data(), cells * sizeof(float));  // x86-64: little-endian
  std::memcpy(read.top.data(), bytes.data() + cells * sizeof(float), cells * sizeof(float));
  *map = std::move(read);
  return true;
}

}  // namespace octo_slice_mapper
