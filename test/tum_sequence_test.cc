// The TUM RGB-D reader: 16-bit depth PNGs, the pinhole back-projection, and both sequence layouts.
#include "tum_sequence.h"

#include <gtest/gtest.h>
#include <png.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/mapper.h"
#include "test_helpers.h"

namespace octo_slice_mapper {
namespace tools {
namespace {

void writeDepthPng(const std::string& path, int width, int height, const std::vector<std::uint16_t>& pixels) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, f);
  png_set_IHDR(png, info, width, height, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_swap(png);
  for (int r = 0; r < height; ++r) {
    png_write_row(png, reinterpret_cast<png_const_bytep>(pixels.data() + std::size_t(r) * width));
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

class TumSequenceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/osm_tum_XXXXXX";
    dir_ = ::mkdtemp(tmpl);
    ::mkdir((dir_ + "/depth").c_str(), 0755);
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }
  void write(const std::string& name, const std::string& text) { std::ofstream(dir_ + "/" + name) << text; }
  std::string dir_;
};

TEST_F(TumSequenceTest, DepthPngsReadBackAndBackProjectThroughThePinhole) {
  const std::vector<std::uint16_t> pixels = {0, 5000, 10000, 65535, 1, 7500};  // 3 x 2
  writeDepthPng(dir_ + "/depth/0000.png", 3, 2, pixels);
  int width = 0, height = 0;
  std::vector<std::uint16_t> read;
  std::string error;
  ASSERT_TRUE(readDepthPng(dir_ + "/depth/0000.png", &width, &height, &read, &error)) << error;
  EXPECT_EQ(width, 3);
  EXPECT_EQ(height, 2);
  EXPECT_EQ(read, pixels) << "the 16-bit values, not byte-swapped";
  const DepthIntrinsics k{500.0, 400.0, 1.0, 0.5, 5000.0};
  const std::vector<Eigen::Vector3f> points = depthPoints(width, height, read, k);
  ASSERT_EQ(points.size(), 6u);
  EXPECT_TRUE(std::isnan(points[0].x())) << "0 is no measurement";
  EXPECT_NEAR(points[1].z(), 1.0f, 1e-6);  // 5000 units: 1 m
  EXPECT_NEAR(points[1].x(), 0.0f, 1e-6);  // u = cx
  EXPECT_NEAR(points[2].x(), 2.0f * (2 - 1.0) / 500.0, 1e-6);
  EXPECT_NEAR(points[2].y(), 2.0f * (0 - 0.5) / 400.0, 1e-6);  // y down: above the centre is negative
  EXPECT_NEAR(points[5].y(), 1.5f * (1 - 0.5) / 400.0, 1e-6);

  // Not a depth image: an 8-bit PNG is refused with a reason.
  std::FILE* f = std::fopen((dir_ + "/eight.png").c_str(), "wb");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, f);
  png_set_IHDR(png, info, 1, 1, 8, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  const png_byte row[1] = {7};
  png_write_row(png, row);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
  EXPECT_FALSE(readDepthPng(dir_ + "/eight.png", &width, &height, &read, &error));
  EXPECT_NE(error.find("16-bit"), std::string::npos) << error;
}

TEST(TumSequence, ADistortedLensIsUndistortedAsTheCalibrationSays) {
  // freiburg1's coefficients: the ray back-projected from a pixel, distorted again, lands on the
  // pixel, across the image, its corners (the strongest distortion) included.
  const DepthIntrinsics k = DepthIntrinsics::freiburg1();
  ASSERT_TRUE(k.distorted());
  for (int v = 0; v < 480; v += 479 / 7) {
    for (int u = 0; u < 640; u += 639 / 9) {
      const Eigen::Vector2d pinhole((u - k.cx) / k.fx, (v - k.cy) / k.fy);
      const Eigen::Vector2d ray = undistortRay(pinhole, k);
      EXPECT_NEAR((distortRay(ray, k) - pinhole).norm(), 0.0, 1e-9) << "pixel " << u << ", " << v;
    }
  }
  // Radial distortion grows outwards: the corner's ray differs from the pinhole's, the centre's not.
  EXPECT_GT((undistortRay({-k.cx / k.fx, -k.cy / k.fy}, k) - Eigen::Vector2d(-k.cx / k.fx, -k.cy / k.fy)).norm(), 0.01);
  EXPECT_NEAR(undistortRay({0.0, 0.0}, k).norm(), 0.0, 1e-12);

  // depthPoints uses the undistorted rays: a pixel at 2 m, distorted back, is the pixel.
  const int width = 640, height = 480;
  std::vector<std::uint16_t> pixels(std::size_t(width) * height, 10000);
  const std::vector<Eigen::Vector3f> points = depthPoints(width, height, pixels, k);
  for (const auto& uv : {std::pair<int, int>{0, 0}, {639, 479}, {320, 240}, {10, 400}}) {
    const Eigen::Vector3f& p = points[std::size_t(uv.second) * width + uv.first];
    EXPECT_FLOAT_EQ(p.z(), 2.0f);
    const Eigen::Vector2d pixel = distortRay(Eigen::Vector2d(p.x() / 2.0, p.y() / 2.0), k);
    EXPECT_NEAR(pixel.x() * k.fx + k.cx, uv.first, 1e-3);
    EXPECT_NEAR(pixel.y() * k.fy + k.cy, uv.second, 1e-3);
  }
}

TEST(TumSequence, CamerasAreNamedOrGivenByTheirIntrinsics) {
  DepthIntrinsics k;
  k.units_per_metre = 1000.0;
  std::string error;
  ASSERT_TRUE(parseDepthIntrinsics("tum", &k, &error)) << error;
  EXPECT_EQ(k.fx, 525.0);
  EXPECT_FALSE(k.distorted());
  ASSERT_TRUE(parseDepthIntrinsics("freiburg2", &k, &error)) << error;
  EXPECT_EQ(k.fx, DepthIntrinsics::freiburg2().fx);
  EXPECT_TRUE(k.distorted());
  EXPECT_EQ(k.units_per_metre, 1000.0) << "the depth scale is not the camera's";
  ASSERT_TRUE(parseDepthIntrinsics("525,525.5,319.5,239.5", &k, &error)) << error;
  EXPECT_EQ(k.fy, 525.5);
  EXPECT_EQ(k.cy, 239.5);
  EXPECT_FALSE(k.distorted());
  ASSERT_TRUE(parseDepthIntrinsics("500,500,320,240,0.1,-0.2,0.001,0.002,0.3", &k, &error)) << error;
  EXPECT_EQ(k.k1, 0.1);
  EXPECT_EQ(k.p2, 0.002);
  EXPECT_EQ(k.k3, 0.3);
  const DepthIntrinsics before = k;
  for (const char* bad : {"freiburg4", "525,525,319.5", "525,525,319.5,x", "0,525,319.5,239.5", "525,525,,239.5",
                          "500,500,320,240,0.1"}) {
    error.clear();
    EXPECT_FALSE(parseDepthIntrinsics(bad, &k, &error)) << bad;
    EXPECT_FALSE(error.empty()) << bad;
    EXPECT_EQ(k.fx, before.fx) << "a refused camera leaves the intrinsics as they were";
  }
}

TEST_F(TumSequenceTest, PosesTxtGivesEachImageInNameOrderItsPose) {
  write("poses.txt", "10.0 1 2 3 0 0 0 1\n10.5 4 5 6 0 0 0.7071068 0.7071068\n");
  writeDepthPng(dir_ + "/depth/0001_depth_raw.png", 1, 1, {1});
  writeDepthPng(dir_ + "/depth/0000_depth_raw.png", 1, 1, {1});
  std::vector<DepthFrame> frames;
  std::string error;
  ASSERT_TRUE(readTumSequence(dir_, &frames, &error)) << error;
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].image, dir_ + "/depth/0000_depth_raw.png");
  EXPECT_TRUE(frames[0].pose.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_DOUBLE_EQ(frames[1].stamp, 10.5);
  EXPECT_TRUE((frames[1].pose.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-6))
      << "turned 90 degrees about z";

  write("poses.txt", "10.0 1 2 3 0 0 0 1\nbroken line\n");
  EXPECT_FALSE(readTumSequence(dir_, &frames, &error));
  EXPECT_NE(error.find("poses.txt:2"), std::string::npos) << error;
}

TEST_F(TumSequenceTest, DepthTxtTakesTheNearestGroundTruthPose) {
  write("groundtruth.txt", "# ground truth\n1.00 0 0 0 0 0 0 1\n1.01 1 0 0 0 0 0 1\n1.02 2 0 0 0 0 0 1\n");
  write("depth.txt", "# depth maps\n1.008 depth/a.png\n1.016 depth/b.png\n1.5 depth/c.png\n");
  std::vector<DepthFrame> frames;
  std::string error;
  ASSERT_TRUE(readTumSequence(dir_, &frames, &error)) << error;
  ASSERT_EQ(frames.size(), 2u) << "the frame 0.48 s from any pose is left out";
  EXPECT_DOUBLE_EQ(frames[0].pose.translation().x(), 1.0);
  EXPECT_DOUBLE_EQ(frames[1].pose.translation().x(), 2.0);
  EXPECT_EQ(frames[1].image, dir_ + "/depth/b.png");

  std::system(("rm " + dir_ + "/groundtruth.txt").c_str());
  EXPECT_FALSE(readTumSequence(dir_, &frames, &error));
  EXPECT_NE(error.find("groundtruth.txt"), std::string::npos) << error;
}

}  // namespace
}  // namespace tools
}  // namespace octo_slice_mapper

// A real Kinect's frames (the shared fr3 cabinet sequence, every other frame): the floor is found
// at the recorded z = 0 (its returns lie between -0.10 and +0.05 m) and, with the world moved
// 1.5 m down as a hand-held camera's frame has it, 1.5 m lower; the navigation slices of the two
// agree cell for cell within one cell.
TEST(TumSequence, ARealFloorIsFoundWhereverTheFixedFrameHasIt) {
  using namespace octo_slice_mapper;
  std::vector<tools::DepthFrame> sequence;
  std::string error;
  ASSERT_TRUE(tools::readTumSequence(test_support::sharedDataDir() + "/tum_fr3_cabinet", &sequence, &error))
      << error << " (set OSM_DATA_DIR)";
  const auto mapped = [&](double lower, FloorStatus* floor) {
    MapperOptions options;
    options.keep_scans = false;
    options.slice.min_z = 0.05;
    options.slice.max_z = 0.80;
    Mapper mapper(options);
    const Eigen::Isometry3d world(Eigen::Translation3d(0.0, 0.0, -lower));
    for (std::size_t i = 0; i < sequence.size(); i += 2) {
      int width = 0, height = 0;
      std::vector<std::uint16_t> pixels;
      EXPECT_TRUE(tools::readDepthPng(sequence[i].image, &width, &height, &pixels, &error)) << error;
      const Eigen::Isometry3d pose = world * sequence[i].pose;
      std::vector<Eigen::Vector3f> points;
      for (const Eigen::Vector3f& p : tools::depthPoints(width, height, pixels, tools::DepthIntrinsics::tum())) {
        if (p.allFinite()) points.push_back((pose * p.cast<double>()).cast<float>());
      }
      EXPECT_TRUE(mapper.insertPoints(pose.translation(), points).ok());
    }
    *floor = mapper.floor().status();
    return gridImageOf(mapper.slice());
  };
  FloorStatus recorded_floor, lowered_floor;
  const GridImage recorded = mapped(0.0, &recorded_floor);
  const GridImage lowered = mapped(1.5, &lowered_floor);
  EXPECT_EQ(recorded_floor.frames_found, 29u);
  EXPECT_NEAR(recorded_floor.height, 0.0, 0.08);
  EXPECT_NEAR(lowered_floor.height, recorded_floor.height - 1.5, 0.01);
  const OccupancyScore score = scoreOccupancy(lowered, recorded, 1);
  EXPECT_GT(recorded_floor.cells, 10000u);
  EXPECT_GT(score.map_occupied, 500u);
  EXPECT_GT(score.precision, 0.97);
  EXPECT_GT(score.recall, 0.97);
  std::printf("fr3 cabinet, floor 1.5 m down against as recorded: %zu occupied cells, precision %.3f, recall %.3f\n",
              score.map_occupied, score.precision, score.recall);
}
