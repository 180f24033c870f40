#include "octo_slice_mapper/map_io.h"

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cstring>
#include <limits>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <set>

#include "octo_slice_mapper/internal/atomic_file.h"
#include "octo_slice_mapper/mapper.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

class MapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/osm_map_io_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    // A small map: a few scans of a wall 2 m ahead.
    for (int k = 0; k < 5; ++k) {
      const auto pose = test_support::laserPoseOnRobot(0.1 * k, 0, 0);
      ASSERT_TRUE(mapper_.insert(test_support::makeScan(pose, -1.0f, 0.01f, std::vector<float>(201, 2.0f))).ok());
    }
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }

  std::string dir_;
  Mapper mapper_;
};

// Every max-depth key of every occupied leaf (pruned leaves expanded).
std::set<octomap::OcTreeKey, bool (*)(const octomap::OcTreeKey&, const octomap::OcTreeKey&)> occupiedKeys(
    const octomap::OcTree& tree) {
  auto less = [](const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
    return std::tie(a[0], a[1], a[2]) < std::tie(b[0], b[1], b[2]);
  };
  std::set<octomap::OcTreeKey, bool (*)(const octomap::OcTreeKey&, const octomap::OcTreeKey&)> keys(less);
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const unsigned span = 1u << (tree.getTreeDepth() - it.getDepth());
    const octomap::OcTreeKey k = it.getKey();
    for (unsigned i = 0; i < span; ++i)
      for (unsigned j = 0; j < span; ++j)
        for (unsigned l = 0; l < span; ++l)
          keys.insert(octomap::OcTreeKey((k[0] & ~(span - 1)) + i, (k[1] & ~(span - 1)) + j, (k[2] & ~(span - 1)) + l));
  }
  return keys;
}

std::map<std::tuple<int, int, int, int>, float> leafLogOdds(const octomap::OcTree& tree) {
  std::map<std::tuple<int, int, int, int>, float> leaves;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const auto k = it.getKey();
    leaves[{k[0], k[1], k[2], int(it.getDepth())}] = it->getLogOdds();
  }
  return leaves;
}

}  // namespace

TEST_F(MapIoTest, BinaryRoundTripKeepsOccupiedLeavesAndLeavesTheLiveTreeAlone) {
  const auto before = leafLogOdds(mapper_.tree());
  const std::size_t nodes_before = mapper_.tree().size();
  std::string error;
  ASSERT_TRUE(saveBinaryTree(mapper_.tree(), dir_ + "/m.bt", &error)) << error;
  EXPECT_EQ(leafLogOdds(mapper_.tree()), before) << "saving must not threshold the live tree";
  EXPECT_EQ(mapper_.tree().size(), nodes_before) << "saving must not prune the live tree";

  octomap::OcTree loaded(0.1);
  std::ifstream in(dir_ + "/m.bt", std::ios::binary);
  ASSERT_TRUE(loaded.readBinary(in)) << "OctoMap's own reader must accept the file";
  EXPECT_DOUBLE_EQ(loaded.getResolution(), 0.05);
  const auto expected = occupiedKeys(mapper_.tree());
  EXPECT_GT(expected.size(), 10u);
  EXPECT_EQ(occupiedKeys(loaded), expected);
}

TEST_F(MapIoTest, FullRoundTripKeepsLogOdds) {
  std::string error;
  ASSERT_TRUE(saveFullTree(mapper_.tree(), dir_ + "/m.ot", &error)) << error;
  auto loaded = loadTree(dir_ + "/m.ot", &error);
  ASSERT_TRUE(loaded) << error;
  EXPECT_EQ(leafLogOdds(*loaded), leafLogOdds(mapper_.tree()));
}

TEST_F(MapIoTest, MapperResumesFromSavedMap) {
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(mapper_.save(dir_ + "/set", &written, &error)) << error;
  EXPECT_EQ(written.size(), 9u) << "PREFIX.{bt,ot,pcd,pgm,yaml,png} and PREFIX_incremental.{pgm,yaml,png}";
  Mapper resumed;
  ASSERT_TRUE(resumed.load(dir_ + "/set.ot", &error)) << error;
  EXPECT_EQ(leafLogOdds(resumed.tree()), leafLogOdds(mapper_.tree()));
  // The resumed slice is rebuilt from the tree: same value for every cell the live one has.
  const SliceGrid& live = mapper_.slice();
  for (int j = 0; j < live.height(); ++j) {
    for (int i = 0; i < live.width(); ++i) {
      const double x = live.originX() + (i + 0.5) * live.resolution(), y = live.originY() + (j + 0.5) * live.resolution();
      ASSERT_EQ(resumed.slice().valueAt(x, y), live.at(i, j)) << x << ", " << y;
    }
  }
}

// The .pcd of a save: one point per occupied voxel of the .bt, at its centre, with its
// probability, read back by PCL's own reader.
TEST_F(MapIoTest, PointCloudFileHoldsTheOccupiedVoxelsAndLoadsWithPcl) {
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(mapper_.save(dir_ + "/set", &written, &error)) << error;
  octomap::OcTree bt(0.1);
  std::ifstream in(dir_ + "/set.bt", std::ios::binary);
  ASSERT_TRUE(bt.readBinary(in));
  const auto expected = occupiedKeys(bt);
  ASSERT_GT(expected.size(), 10u);

  pcl::PCLPointCloud2 blob;
  ASSERT_EQ(pcl::io::loadPCDFile(dir_ + "/set.pcd", blob), 0) << "PCL must read the file";
  std::vector<std::string> fields;
  for (const auto& f : blob.fields) fields.push_back(f.name);
  EXPECT_EQ(fields, (std::vector<std::string>{"x", "y", "z", "occupancy"}));
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl::fromPCLPointCloud2(blob, cloud);
  ASSERT_EQ(cloud.size(), expected.size()) << "one point per occupied voxel of the .bt";
  auto less = [](const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
    return std::tie(a[0], a[1], a[2]) < std::tie(b[0], b[1], b[2]);
  };
  std::set<octomap::OcTreeKey, decltype(less)> keys(less);
  for (const auto& p : cloud) {
    const octomap::OcTreeKey key = bt.coordToKey(p.x, p.y, p.z);
    EXPECT_NEAR(bt.keyToCoord(key[0]), p.x, 1e-4) << "the voxel's centre";
    keys.insert(key);
  }
  EXPECT_EQ(keys.size(), expected.size()) << "each voxel once";
  EXPECT_TRUE(std::equal(keys.begin(), keys.end(), expected.begin(), expected.end()));
  // The probabilities are the live tree's.
  const std::size_t occupancy_offset = blob.fields[3].offset;
  for (std::size_t k = 0; k < cloud.size(); k += 7) {
    float p = 0.0f;
    std::memcpy(&p, blob.data.data() + k * blob.point_step + occupancy_offset, sizeof p);
    const octomap::OcTreeNode* node = mapper_.tree().search(double(cloud[k].x), cloud[k].y, cloud[k].z);
    ASSERT_NE(node, nullptr);
    EXPECT_NEAR(p, node->getOccupancy(), 1e-6);
  }
  EXPECT_FALSE(readSaveId(dir_ + "/set.pcd").empty()) << "it belongs to the set";
  EXPECT_EQ(readSaveId(dir_ + "/set.pcd"), readSaveId(dir_ + "/set.bt"));
}

// A pruned occupied node stands for every leaf it holds; free voxels are left out.
TEST(OccupiedVoxelsTest, APrunedNodeGivesEachOfItsLeaves) {
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) tree.setNodeValue(octomap::OcTreeKey(32768 + i, 32768 + j, 32768 + k), 3.5f);
  tree.setNodeValue(octomap::OcTreeKey(32800, 32768, 32768), -2.0f);  // free
  tree.setNodeValue(octomap::OcTreeKey(32801, 32768, 32768), 1.0f);   // occupied, alone
  tree.prune();
  ASSERT_LT(tree.getNumLeafNodes(), 64u) << "the block is pruned";
  const std::vector<OccupiedVoxel> voxels = occupiedVoxels(tree);
  ASSERT_EQ(voxels.size(), 65u);
  std::set<std::tuple<int, int, int>> cells;
  for (const OccupiedVoxel& v : voxels) {
    cells.insert({int(std::floor(v.x / 0.05)), int(std::floor(v.y / 0.05)), int(std::floor(v.z / 0.05))});
  }
  EXPECT_EQ(cells.size(), 65u) << "each leaf once";
  for (int i = 0; i < 4; ++i) EXPECT_EQ(cells.count({i, i, i}), 1u);
  EXPECT_EQ(cells.count({33, 0, 0}), 1u);
  EXPECT_EQ(cells.count({32, 0, 0}), 0u) << "a free voxel is no point";
}

TEST_F(MapIoTest, PgmYamlFollowMapServerConventions) {
  std::string error;
  const GridImage grid = gridImageOf(mapper_.slice());
  ASSERT_TRUE(savePgmYaml(grid, dir_ + "/m", &error)) << error;
  GridImage back;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/m.yaml", &back, &error)) << error;
  ASSERT_EQ(back.width, grid.width);
  ASSERT_EQ(back.height, grid.height);
  EXPECT_NEAR(back.origin_x, grid.origin_x, 1e-6);
  EXPECT_NEAR(back.origin_y, grid.origin_y, 1e-6);
  std::size_t occupied = 0, free_cells = 0;
  for (std::size_t k = 0; k < grid.cells.size(); ++k) {
    const int v = grid.cells[k];
    const int expected = v < 0 ? -1 : v > 65 ? 100 : v < 19.6 ? 0 : -1;
    ASSERT_EQ(back.cells[k], expected) << "cell " << k << " value " << v;
    occupied += expected == 100;
    free_cells += expected == 0;
  }
  EXPECT_GT(occupied, 10u);
  EXPECT_GT(free_cells, 100u);
  std::ifstream yaml(dir_ + "/m.yaml");
  std::string text((std::istreambuf_iterator<char>(yaml)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("image: m.pgm"), std::string::npos);
  EXPECT_NE(text.find("negate: 0"), std::string::npos);
}

TEST_F(MapIoTest, PngIsAValidPicture) {
  std::string error;
  ASSERT_TRUE(savePng(gridImageOf(mapper_.slice()), dir_ + "/m.png", &error)) << error;
  std::string bytes;
  ASSERT_TRUE(readFile(dir_ + "/m.png", &bytes, &error));
  ASSERT_GT(bytes.size(), 100u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
}

// The incremental map's picture: the map's own bytes where the two grids are the same, drawn
// from its own grid where they differ in a single cell.
TEST_F(MapIoTest, IncrementalPictureIsTheMapsOnlyWhereTheGridsAreEqual) {
  const GridImage grid = gridImageOf(mapper_.slice());
  GridImage changed = grid;
  ASSERT_FALSE(changed.cells.empty());
  changed.cells[changed.cells.size() / 2] = changed.cells[changed.cells.size() / 2] == 100 ? 0 : 100;
  const GridImage equal = grid;  // another object with the same cells
  std::string error, map_png, incremental_png;
  for (const GridImage* incremental : {&equal, static_cast<const GridImage*>(&changed)}) {
    std::vector<std::string> written;
    ASSERT_TRUE(saveMapSet(mapper_.tree(), grid, dir_ + "/set", &written, &error, incremental)) << error;
    ASSERT_TRUE(readFile(dir_ + "/set.png", &map_png, &error)) << error;
    ASSERT_TRUE(readFile(dir_ + "/set_incremental.png", &incremental_png, &error)) << error;
    EXPECT_EQ(incremental_png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    if (incremental == &equal) {
      EXPECT_EQ(incremental_png, map_png);
    } else {
      EXPECT_NE(incremental_png, map_png);
    }
  }
}

namespace {
// A small raster of unknown cells at `origin` (0.1 m cells).
GridImage unknownGrid(int width, int height, double origin_x, double origin_y) {
  GridImage g;
  g.width = width, g.height = height, g.resolution = 0.1, g.origin_x = origin_x, g.origin_y = origin_y;
  g.cells.assign(std::size_t(width) * height, -1);
  return g;
}
}  // namespace

TEST(InFrameOfTest, DrawsAGridInAnotherFrameCellForCell) {
  const GridImage frame = unknownGrid(10, 8, 1.0, 2.0);
  GridImage grid = unknownGrid(4, 4, 1.5, 2.3);  // 5 cells right of and 3 above the frame's corner
  grid.cells[std::size_t(1) * grid.width + 2] = 100;
  grid.cells[std::size_t(3) * grid.width + 0] = 0;
  const GridImage out = inFrameOf(grid, frame);
  EXPECT_EQ(out.width, frame.width);
  EXPECT_EQ(out.height, frame.height);
  EXPECT_NEAR(out.origin_x, frame.origin_x, 1e-12);
  EXPECT_NEAR(out.origin_y, frame.origin_y, 1e-12);
  int known = 0;
  for (int j = 0; j < out.height; ++j) {
    for (int i = 0; i < out.width; ++i) known += out.at(i, j) >= 0;
  }
  EXPECT_EQ(known, 2);
  EXPECT_EQ(out.at(7, 4), 100);
  EXPECT_EQ(out.at(5, 6), 0);
}

TEST(InFrameOfTest, GrowsTheFrameToKeepEveryKnownCell) {
  const GridImage frame = unknownGrid(10, 8, 1.0, 2.0);
  GridImage grid = unknownGrid(3, 3, 0.7, 2.0);  // starts 3 cells left of the frame
  grid.cells[0] = 100;                            // that leftmost column, bottom row
  grid.cells[std::size_t(2) * grid.width + 2] = 0;
  const GridImage out = inFrameOf(grid, frame);
  EXPECT_EQ(out.width, 13);
  EXPECT_EQ(out.height, 8);
  EXPECT_NEAR(out.origin_x, 0.7, 1e-12);
  EXPECT_NEAR(out.origin_y, 2.0, 1e-12);
  EXPECT_EQ(out.at(0, 0), 100);
  EXPECT_EQ(out.at(2, 2), 0);
  // Unknown cells of the grid outside the frame do not grow it.
  GridImage far_unknown = unknownGrid(3, 3, -5.0, -5.0);
  const GridImage same = inFrameOf(far_unknown, frame);
  EXPECT_EQ(same.width, frame.width);
  EXPECT_EQ(same.height, frame.height);
}

TEST(InFrameOfTest, LeavesAGridOfAnotherResolutionAlone) {
  GridImage grid = unknownGrid(3, 3, 0.0, 0.0);
  grid.resolution = 0.05;
  grid.cells[4] = 100;
  const GridImage out = inFrameOf(grid, unknownGrid(10, 8, 1.0, 2.0));
  EXPECT_EQ(out.width, 3);
  EXPECT_EQ(out.cells, grid.cells);
}

TEST_F(MapIoTest, FailedSaveLeavesNothingHalfWritten) {
  std::string error;
  EXPECT_FALSE(saveBinaryTree(mapper_.tree(), dir_ + "/missing/m.bt", &error));
  EXPECT_NE(error.find("missing"), std::string::npos);
  // A good map already there survives a failing save of an empty map, and no temp files stay.
  ASSERT_TRUE(writeFileAtomically(dir_ + "/m.pgm", "old", &error));
  GridImage empty;
  EXPECT_FALSE(savePgmYaml(empty, dir_ + "/m", &error));
  std::string bytes;
  ASSERT_TRUE(readFile(dir_ + "/m.pgm", &bytes, &error));
  EXPECT_EQ(bytes, "old");
  EXPECT_EQ(test_support::filesIn(dir_), std::vector<std::string>{"m.pgm"});
}

TEST_F(MapIoTest, CorruptOrWrongFilesAreRefusedWithAReason) {
  std::string error;
  ASSERT_TRUE(saveBinaryTree(mapper_.tree(), dir_ + "/good.bt", &error));
  std::string bytes;
  ASSERT_TRUE(readFile(dir_ + "/good.bt", &bytes, &error));
  ASSERT_TRUE(writeFileAtomically(dir_ + "/truncated.bt", bytes.substr(0, bytes.size() / 2), &error));
  ASSERT_TRUE(writeFileAtomically(dir_ + "/text.bt", "hello, not a map\n", &error));
  for (const char* name : {"truncated.bt", "text.bt", "absent.bt"}) {
    error.clear();
    EXPECT_EQ(loadTree(dir_ + "/" + name, &error), nullptr) << name;
    EXPECT_FALSE(error.empty()) << name;
  }
  // A truncated .ot: OctoMap's reader returns a tree from what is there, it is refused.
  ASSERT_TRUE(saveFullTree(mapper_.tree(), dir_ + "/good.ot", &error));
  ASSERT_TRUE(readFile(dir_ + "/good.ot", &bytes, &error));
  ASSERT_NE(loadTree(dir_ + "/good.ot", &error), nullptr) << error;
  for (double share : {0.5, 0.9, 0.999}) {
    const std::string name = dir_ + "/truncated_" + std::to_string(share) + ".ot";
    ASSERT_TRUE(writeFileAtomically(name, bytes.substr(0, std::size_t(share * bytes.size())), &error));
    error.clear();
    EXPECT_EQ(loadTree(name, &error), nullptr) << share;
    EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  }
  // A node's value bit-flipped to NaN (the first node's float follows the header's "data" line).
  std::string flipped = bytes;
  const std::size_t data = flipped.find("\ndata\n") + 6;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&flipped[data], &nan, sizeof nan);
  ASSERT_TRUE(writeFileAtomically(dir_ + "/nan.ot", flipped, &error));
  EXPECT_EQ(loadTree(dir_ + "/nan.ot", &error), nullptr);
  EXPECT_NE(error.find("finite"), std::string::npos) << error;
  Mapper keeps;
  ASSERT_TRUE(keeps.insert(test_support::makeScan(test_support::laserPoseOnRobot(0, 0, 0), 0.0f, 0.01f, {1.0f})).ok());
  const auto before = leafLogOdds(keeps.tree());
  EXPECT_FALSE(keeps.load(dir_ + "/truncated.bt", &error));
  EXPECT_EQ(leafLogOdds(keeps.tree()), before) << "a failed load keeps the current map";
}
