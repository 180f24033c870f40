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

// A depth camera with the plumb-bob lens model (ROS's camera_info, OpenCV's): pixel (u, v) with depth d (m)
// is the point (x d, y d, d) in the optical frame (x right, y down, z forward), where (x, y) is the
// undistorted ray whose distortion by k1, k2, p1, p2, k3 lands on ((u - cx) / fx, (v - cy) / fy).
// Zero coefficients: a pinhole, x = (u - cx) / fx.
struct DepthIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  double units_per_metre = 5000.0;  // TUM's depth scale
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  // The conversion the TUM benchmark documents for the depth images of every sequence: the OpenNI
  // driver undistorted them and registered them to the colour camera with the Kinect's factory
  // calibration (ROS's default intrinsics). The colour calibrations below do not describe those
  // images: through them fr1's floor lies off the motion capture's (doc/benchmarks.md).
  static DepthIntrinsics tum() { return {525.0, 525.0, 319.5, 239.5}; }
  // The TUM benchmark's calibrations of the colour cameras, for images in their raw geometry.
  // freiburg1's and freiburg2's lenses distort: their coefficients are applied here, as a ROS
  // driver's rectification would. freiburg3's images are undistorted already.
  static DepthIntrinsics freiburg1() {
    return {517.3, 516.5, 318.6, 255.3, 5000.0, 0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  }
  static DepthIntrinsics freiburg2() {
    return {520.9, 521.0, 325.1, 249.7, 5000.0, 0.2312, -0.7849, -0.0033, -0.0001, 0.9172};
  }
  static DepthIntrinsics freiburg3() { return {535.4, 539.2, 320.1, 247.6}; }
  bool distorted() const { return k1 != 0.0 || k2 != 0.0 || p1 != 0.0 || p2 != 0.0 || k3 != 0.0; }
};

// A camera by name (tum, freiburg1, freiburg2, freiburg3), or "fx,fy,cx,cy" with optionally
// ",k1,k2,p1,p2,k3" after it; units_per_metre is left as it is. False with the reason.
bool parseDepthIntrinsics(const std::string& text, DepthIntrinsics* intrinsics, std::string* error);

// The plumb-bob distortion of the undistorted ray (x, y): where it lands on the normalized image.
Eigen::Vector2d distortRay(const Eigen::Vector2d& ray, const DepthIntrinsics& k);
// Its inverse, by fixed-point iteration (as OpenCV's undistortPoints), to 1e-12 or 100 rounds.
Eigen::Vector2d undistortRay(const Eigen::Vector2d& distorted, const DepthIntrinsics& k);

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
