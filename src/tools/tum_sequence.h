// TUM RGB-D sequences (Sturm et al., IROS 2012): 640 x 480 16-bit depth PNGs with the camera's
// motion-capture pose per frame, read into depth frames in a fixed frame; for mapping real depth
// cameras offline (tum2bag writes them as a bag of PointCloud2 and tf).
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <string>
#include <vector>

namespace octo_slice_mapper {
namespace tools {

// A pinhole depth camera: pixel (u, v) with depth d (m) is the point ((u - cx) d / fx, (v - cy) d / fy, d)
// in the optical frame (x right, y down, z forward).
struct DepthIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double units_per_metre = 5000.0;  // TUM's depth scale
  static DepthIntrinsics freiburg1() { return {517.3, 516.5, 318.6, 255.3}; }
  static DepthIntrinsics freiburg3() { return {535.4, 539.2, 320.1, 247.6}; }
};

struct DepthFrame {
  double stamp = 0.0;        // s
  std::string image;         // path of the depth PNG
  Eigen::Isometry3d pose;    // optical frame in the world frame (z up)
};

// The frames of a sequence folder in one of its two layouts: depth.txt ("timestamp file") with
// groundtruth.txt (poses at 100 Hz: the one nearest each frame's stamp is taken, if within
// 20 ms), or poses.txt (line i the pose of depth/ file i in name order). False with the reason
// if neither can be read, or a line is malformed.
bool readTumSequence(const std::string& folder, std::vector<DepthFrame>* frames, std::string* error);

// A 16-bit greyscale PNG's pixels, row by row (0: no measurement). False with the reason.
bool readDepthPng(const std::string& path, int* width, int* height, std::vector<std::uint16_t>* pixels,
                  std::string* error);

// The points of a depth image in the optical frame, one per pixel, row by row; NaN where there is
// no measurement (an organized cloud, as a camera driver sends it).
std::vector<Eigen::Vector3f> depthPoints(int width, int height, const std::vector<std::uint16_t>& pixels,
                                         const DepthIntrinsics& intrinsics);

}  // namespace tools
}  // namespace octo_slice_mapper
