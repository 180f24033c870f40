// tum2bag: a TUM RGB-D sequence (depth PNGs and motion-capture poses) as a rosbag of organized
// PointCloud2 frames and tf, so that octo_slice_map and replay.launch map real depth cameras:
//
//   tum2bag FOLDER OUT.bag [--camera tum|freiburg1|freiburg2|freiburg3|fx,fy,cx,cy[,k1,k2,p1,p2,k3]]
//           [--depth-scale UNITS_PER_METRE] [--lower M] [--tilt DEG] [--fixed-frame odom]
//   octo_slice_map --bag OUT.bag --scan-topic '' --cloud-topic /camera/depth/points
//       --slice-min-z 0.05 --slice-max-z 0.80
//
// --camera: tum (the default) is the conversion the TUM benchmark documents for its depth images
// (registered to the colour camera by the driver); freiburg1..3 are its colour cameras'
// calibrations; or another camera's intrinsics (pixels) and plumb-bob lens coefficients.
// --depth-scale is the depth PNGs' units per metre (5000).
// --lower M moves the world down by M (the floor at z = -M) and --tilt DEG turns it about the
// x axis: the same frames in another fixed frame, as a robot whose odometry origin is not on the
// floor, or whose camera mount is off by a degree or two, would record them.
#include <ros/time.h>
#include <rosbag/bag.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <iostream>
#include <string>

#include "bag_file.h"
#include "progress_bar.h"
#include "ros/point_cloud_conversion.h"
#include "tum_sequence.h"

namespace {

const char kUsage[] =
    "usage: tum2bag FOLDER OUT.bag [--camera tum|freiburg1|freiburg2|freiburg3|fx,fy,cx,cy[,k1,k2,p1,p2,k3]]\n"
    "               [--depth-scale UNITS_PER_METRE] [--lower M] [--tilt DEG] [--fixed-frame odom]\n";

}  // namespace

int main(int argc, char** argv) {
  namespace tools = octo_slice_mapper::tools;
  std::string folder, bag_path, camera = "tum", fixed_frame = "odom";
  double lower = 0.0, tilt_deg = 0.0, depth_scale = 5000.0;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--camera" && i + 1 < argc) camera = argv[++i];
      else if (arg == "--depth-scale" && i + 1 < argc) depth_scale = std::stod(argv[++i]);
      else if (arg == "--lower" && i + 1 < argc) lower = std::stod(argv[++i]);
      else if (arg == "--tilt" && i + 1 < argc) tilt_deg = std::stod(argv[++i]);
      else if (arg == "--fixed-frame" && i + 1 < argc) fixed_frame = argv[++i];
      else if (arg[0] != '-' && folder.empty()) folder = arg;
      else if (arg[0] != '-' && bag_path.empty()) bag_path = arg;
      else throw std::invalid_argument(arg);
    }
  } catch (const std::exception&) {
    std::cerr << kUsage;
    return 2;
  }
  if (folder.empty() || bag_path.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  std::string error;
  tools::DepthIntrinsics intrinsics;
  intrinsics.units_per_metre = depth_scale;
  if (!(depth_scale > 0.0) || !tools::parseDepthIntrinsics(camera, &intrinsics, &error)) {
    std::cerr << "tum2bag: " << (depth_scale > 0.0 ? error : "--depth-scale must be > 0") << "\n" << kUsage;
    return 2;
  }
  std::vector<tools::DepthFrame> frames;
  if (!tools::readTumSequence(folder, &frames, &error)) {
    std::cerr << "tum2bag: " << error << "\n";
    return 1;
  }
  if (frames.empty()) {
    std::cerr << "tum2bag: " << folder << ": no frame has a pose\n";
    return 1;
  }
  // The world as the bag's fixed frame sees it: turned about x, then moved down.
  const Eigen::Isometry3d world = Eigen::Translation3d(0.0, 0.0, -lower) *
                                  Eigen::AngleAxisd(tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitX());
  const std::string optical = "camera_depth_optical_frame";
  tools::ProgressBar bar;
  std::size_t written = 0;
  const bool ok = tools::writeBagWhole(bag_path, [&](rosbag::Bag& bag, std::string* why) {
    for (std::size_t k = 0; k < frames.size(); ++k) {
      bar.update("converting", double(k) / frames.size());
      int width = 0, height = 0;
      std::vector<std::uint16_t> pixels;
      std::string unread;
      if (!tools::readDepthPng(frames[k].image, &width, &height, &pixels, &unread)) {
        std::cerr << "tum2bag: " << unread << ": frame left out\n";
        continue;
      }
      const ros::Time stamp(frames[k].stamp);
      geometry_msgs::TransformStamped t = tf2::eigenToTransform(world * frames[k].pose);
      t.header.stamp = stamp;
      t.header.frame_id = fixed_frame;
      t.child_frame_id = optical;
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(t);
      bag.write("/tf", stamp, tf);
      sensor_msgs::PointCloud2 cloud = octo_slice_mapper::ros_adapter::organizedCloud(
          tools::depthPoints(width, height, pixels, intrinsics), width, height, optical);
      cloud.header.stamp = stamp;
      cloud.header.seq = static_cast<std::uint32_t>(k);
      bag.write("/camera/depth/points", stamp + ros::Duration(0.001), cloud);  // after its pose
      ++written;
    }
    if (written == 0) *why = folder + ": no depth image could be read";
    return written > 0;
  }, &error);
  bar.finish();
  if (!ok) {
    std::cerr << "tum2bag: " << error << "\n";
    return 1;
  }
  std::cout << "tum2bag: wrote " << bag_path << " (" << written << " depth frames of " << frames.size() << ")\n";
  return 0;
}
