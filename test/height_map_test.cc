// The height map: the floor found and the top of what stands on it, per cell of the saved map,
// saved as data and as a picture; a map without a floor found saves none.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>
#include <string>

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

}  // namespace

TEST(HeightMap, HoldsTheFloorFoundAndTheTopOfWhatStandsOnIt) {
  MapperOptions options;
  options.slice.min_z = 0.05;
  options.slice.max_z = 0.80;
  Mapper mapper(options);
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(mapper.insertPoints(Eigen::Vector3d(0.0, 0.0, -0.3), floorAndBox()).ok());
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
