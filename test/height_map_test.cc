// The height map: the floor found and the top of what stands on it, per cell of the saved map,
// saved as data and as a picture; a map without a floor found saves none.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>
#include <string>

#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/internal/height_map.h"
#include "octo_slice_mapper/mapper.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

// A directory of its own, removed with everything in it.
class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/osm_height_map_XXXXXX";
    if (::mkdtemp(tmpl)) path_ = tmpl;
  }
  ~TempDir() {
    if (!path_.empty()) std::system(("rm -rf " + path_).c_str());
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// A hand-held camera's frame with the floor 1.5 m below the fixed frame's zero and a box 0.5 m
// high on it at x 2.0-2.3, seen from 1.2 m above the floor.
std::vector<Eigen::Vector3f> floorAndBox() {
  std::vector<Eigen::Vector3f> points;
  for (double x = 0.5; x < 3.0; x += 0.02) {
    for (double y = -1.0; y < 1.0; y += 0.02) {
      const bool box = x >= 2.0 && x < 2.3 && std::abs(y) < 0.15;
      points.emplace_back(float(x), float(y), float(-1.5 + (box ? 0.5 : 0.0)));
    }
  }
  return points;
}

// The navigation band: the box stands in it.
MapperOptions navigationBand() {
  MapperOptions options;
  options.slice.min_z = 0.05;
  options.slice.max_z = 0.80;
  return options;
}

// Three frames of floorAndBox() from 1.2 m above the floor.
void mapFloorAndBox(Mapper* mapper) {
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(mapper->insertPoints(Eigen::Vector3d(0.0, 0.0, -0.3), floorAndBox()).ok());
}

}  // namespace

TEST(HeightMap, HoldsTheFloorFoundAndTheTopOfWhatStandsOnIt) {
  Mapper mapper(navigationBand());
  mapFloorAndBox(&mapper);
  const GridImage frame = gridImageOf(mapper.slice());
  const HeightMap map = heightMapOf(mapper.tree(), mapper.floor(), frame);
  ASSERT_FALSE(map.empty());
  const auto at = [&](const std::vector<float>& grid, double x, double y) {
    const int i = int(std::floor((x - map.origin_x) / map.resolution)), j = int(std::floor((y - map.origin_y) / map.resolution));
    return grid[std::size_t(j) * map.width + i];
  };
  EXPECT_NEAR(at(map.floor, 1.0, 0.0), -1.5, 0.02);
  EXPECT_TRUE(std::isnan(at(map.top, 1.0, 0.0)));  // floor, nothing on it
  EXPECT_NEAR(at(map.top, 2.125, 0.025), 0.5, 0.06);

  TempDir dir;
  const std::string prefix = dir.path() + "/box";
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(mapper.save(prefix, &written, &error)) << error;
  EXPECT_EQ(written.size(), 12u);
  std::FILE* f = std::fopen((prefix + "_heights.bin").c_str(), "rb");
  ASSERT_NE(f, nullptr);
  std::vector<float> data(2 * std::size_t(map.width) * map.height);
  EXPECT_EQ(std::fread(data.data(), sizeof(float), data.size(), f), data.size());
  EXPECT_EQ(std::fgetc(f), EOF);  // nothing more
  std::fclose(f);
  const std::size_t cells = std::size_t(map.width) * map.height;
  std::size_t same = 0;
  for (std::size_t c = 0; c < cells; ++c) {
    same += (std::isnan(data[c]) && std::isnan(map.floor[c])) || data[c] == map.floor[c];
  }
  EXPECT_EQ(same, cells);
  EXPECT_FALSE(readSaveId(prefix + "_heights.yaml").empty());
  EXPECT_EQ(readSaveId(prefix + "_heights.yaml"), readSaveId(prefix + ".bt"));
  // The same map under another name has the same id (the .yaml files' first lines, which name
  // the set's other files, are left out of it).
  ASSERT_TRUE(mapper.save(dir.path() + "/other", &written, &error)) << error;
  EXPECT_EQ(readSaveId(dir.path() + "/other.bt"), readSaveId(prefix + ".bt"));
  std::FILE* png = std::fopen((prefix + "_heights.png").c_str(), "rb");
  ASSERT_NE(png, nullptr);
  unsigned char signature[8];
  EXPECT_EQ(std::fread(signature, 1, 8, png), 8u);
  std::fclose(png);
  EXPECT_EQ(std::memcmp(signature, "\x89PNG\r\n\x1a\n", 8), 0);
}

TEST(HeightMap, AMapWithoutAFloorFoundSavesNone) {
  Mapper mapper{MapperOptions()};
  const Scan scan = test_support::makeScan(Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 0.26)), -1.0f, 0.01f,
                                           std::vector<float>(200, 3.0f), 0.1f, 10.0f);
  ASSERT_TRUE(mapper.insert(scan).ok());
  EXPECT_TRUE(heightMapOf(mapper.tree(), mapper.floor(), gridImageOf(mapper.slice())).empty());
  TempDir dir;
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(mapper.save(dir.path() + "/lidar", &written, &error)) << error;
  EXPECT_EQ(written.size(), 9u);
}

TEST(HeightMap, ALoadedMapKeepsTheFloorItWasFoundWith) {
  const MapperOptions options = navigationBand();
  Mapper mapper(options);
  mapFloorAndBox(&mapper);
  const GridImage saved = gridImageOf(mapper.slice());
  TempDir dir;
  const std::string prefix = dir.path() + "/box";
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(mapper.save(prefix, &written, &error)) << error;
  HeightMap heights;
  ASSERT_TRUE(readHeightMap(prefix + "_heights.yaml", &heights, &error)) << error;
  EXPECT_NEAR(heights.fallback_floor, mapper.floor().fallbackHeight(), 1e-6);

  // The box stands 0.05-0.80 m above a floor 1.5 m down: loaded, the slice shows it where the
  // saved one did (from the fixed frame's z = 0 it would see nothing).
  for (const char* ending : {".bt", ".ot"}) {
    Mapper loaded(options);
    ASSERT_TRUE(loaded.load(prefix + ending, &error)) << error;
    EXPECT_EQ(loaded.floor().status().cells, mapper.floor().status().cells) << ending;
    EXPECT_NEAR(loaded.floor().fallbackHeight(), mapper.floor().fallbackHeight(), 1e-6) << ending;
    EXPECT_GT(loaded.slice().valueAt(2.125, 0.025), 50) << ending << ": the box";
    EXPECT_LT(loaded.slice().valueAt(1.0, 0.0), 50) << ending << ": the floor, free above it";
    const GridImage again = gridImageOf(loaded.slice());
    const OccupancyScore score = scoreOccupancy(again, saved, 0);
    EXPECT_EQ(score.precision, 1.0) << ending;
    EXPECT_EQ(score.recall, 1.0) << ending;
    // Frames after the load are measured against that floor and go on finding it.
    ASSERT_TRUE(loaded.insertPoints(Eigen::Vector3d(0.0, 0.0, -0.3), floorAndBox()).ok());
    EXPECT_NEAR(loaded.floor().status().height, -1.5, 0.02) << ending;
    EXPECT_GT(loaded.slice().valueAt(2.125, 0.025), 50) << ending;
  }

  // A height map of another save under the same name (another save id) is not this map's floor.
  Mapper lidar{MapperOptions()};
  const Scan scan = test_support::makeScan(Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, 0.26)), -1.0f, 0.01f,
                                           std::vector<float>(200, 3.0f), 0.1f, 10.0f);
  ASSERT_TRUE(lidar.insert(scan).ok());
  ASSERT_TRUE(lidar.save(prefix, &written, &error)) << error;  // box_heights.* stay, stale
  Mapper other(options);
  ASSERT_TRUE(other.load(prefix + ".bt", &error)) << error;
  EXPECT_EQ(other.floor().status().cells, 0u);

  // This map's height map, damaged: the load is refused with the reason, the map in place kept.
  ASSERT_TRUE(mapper.save(prefix, &written, &error)) << error;
  std::FILE* bin = std::fopen((prefix + "_heights.bin").c_str(), "wb");
  ASSERT_NE(bin, nullptr);
  std::fputs("short", bin);
  std::fclose(bin);
  Mapper keeps(options);
  ASSERT_TRUE(keeps.insert(scan).ok());
  const std::size_t known = keeps.slice().knownCells();
  error.clear();
  EXPECT_FALSE(keeps.load(prefix + ".bt", &error));
  EXPECT_NE(error.find("_heights.bin"), std::string::npos) << error;
  EXPECT_EQ(keeps.slice().knownCells(), known);
}
