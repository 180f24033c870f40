#include "tum_sequence.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <dirent.h>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace octo_slice_mapper {
namespace tools {
namespace {

bool readPoseLine(const std::string& line, double* stamp, Eigen::Isometry3d* pose) {
  std::istringstream in(line);
  double t, x, y, z, qx, qy, qz, qw;
  if (!(in >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) return false;
  const Eigen::Quaterniond q(qw, qx, qy, qz);
  if (!std::isfinite(q.norm()) || q.norm() < 0.5) return false;
  *stamp = t;
  *pose = Eigen::Isometry3d::Identity();
  pose->linear() = q.normalized().toRotationMatrix();
  pose->translation() = Eigen::Vector3d(x, y, z);
  return true;
}

bool comment(const std::string& line) { return line.empty() || line[0] == '#'; }

}  // namespace

bool readTumSequence(const std::string& folder, std::vector<DepthFrame>* frames, std::string* error) {
  frames->clear();
  std::ifstream listed(folder + "/depth.txt");
  if (listed) {
    std::ifstream truth(folder + "/groundtruth.txt");
    if (!truth) {
      *error = folder + ": depth.txt without groundtruth.txt";
      return false;
    }
    std::map<double, Eigen::Isometry3d> poses;
    std::string line;
    for (int n = 1; std::getline(truth, line); ++n) {
      if (comment(line)) continue;
      double t;
      Eigen::Isometry3d pose;
      if (!readPoseLine(line, &t, &pose)) {
        *error = folder + "/groundtruth.txt:" + std::to_string(n) + ": not \"timestamp tx ty tz qx qy qz qw\"";
        return false;
      }
      poses.emplace(t, pose);
    }
    for (int n = 1; std::getline(listed, line); ++n) {
      if (comment(line)) continue;
      std::istringstream in(line);
      DepthFrame frame;
      if (!(in >> frame.stamp >> frame.image)) {
        *error = folder + "/depth.txt:" + std::to_string(n) + ": not \"timestamp file\"";
        return false;
      }
      // The nearest pose in time; none within 20 ms (two motion-capture samples): left out.
      auto after = poses.lower_bound(frame.stamp);
      auto best = poses.end();
      if (after != poses.end()) best = after;
      if (after != poses.begin()) {
        auto before = std::prev(after);
        if (best == poses.end() || frame.stamp - before->first < best->first - frame.stamp) best = before;
      }
      if (best == poses.end() || std::abs(best->first - frame.stamp) > 0.02) continue;
      frame.image = folder + "/" + frame.image;
      frame.pose = best->second;
      frames->push_back(frame);
    }
    return true;
  }
  std::ifstream posed(folder + "/poses.txt");
  if (!posed) {
    *error = folder + ": neither depth.txt nor poses.txt";
    return false;
  }
  std::vector<std::string> images;
  if (DIR* dir = ::opendir((folder + "/depth").c_str())) {
    while (const dirent* e = ::readdir(dir)) {
      const std::string name = e->d_name;
      if (name.size() > 4 && name.compare(name.size() - 4, 4, ".png") == 0) images.push_back(name);
    }
    ::closedir(dir);
  }
  std::sort(images.begin(), images.end());
  std::string line;
  std::size_t k = 0;
  for (int n = 1; std::getline(posed, line); ++n) {
    if (comment(line)) continue;
    DepthFrame frame;
    if (!readPoseLine(line, &frame.stamp, &frame.pose)) {
      *error = folder + "/poses.txt:" + std::to_string(n) + ": not \"timestamp tx ty tz qx qy qz qw\"";
      return false;
    }
    if (k >= images.size()) {
      *error = folder + "/poses.txt: more poses than depth images (" + std::to_string(images.size()) + ")";
      return false;
    }
    frame.image = folder + "/depth/" + images[k++];
    frames->push_back(frame);
  }
  return true;
}

bool readDepthPng(const std::string& path, int* width, int* height, std::vector<std::uint16_t>* pixels,
                  std::string* error) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    *error = path + ": cannot open";
    return false;
  }
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    *error = path + ": not a readable PNG";
    return false;
  }
  png_init_io(png, f);
  png_read_info(png, info);
  const int bits = png_get_bit_depth(png, info), colour = png_get_color_type(png, info);
  if (bits != 16 || colour != PNG_COLOR_TYPE_GRAY) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::fclose(f);
    *error = path + ": not a 16-bit greyscale PNG (a depth image)";
    return false;
  }
  png_set_swap(png);  // PNG stores 16-bit samples big-endian
  *width = static_cast<int>(png_get_image_width(png, info));
  *height = static_cast<int>(png_get_image_height(png, info));
  pixels->assign(std::size_t(*width) * *height, 0);
  std::vector<png_bytep> rows(*height);
  for (int r = 0; r < *height; ++r) rows[r] = reinterpret_cast<png_bytep>(pixels->data() + std::size_t(r) * *width);
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  std::fclose(f);
  return true;
}

bool parseDepthIntrinsics(const std::string& text, DepthIntrinsics* intrinsics, std::string* error) {
  const double units = intrinsics->units_per_metre;
  if (text == "tum" || text == "freiburg1" || text == "freiburg2" || text == "freiburg3") {
    *intrinsics = text == "tum"         ? DepthIntrinsics::tum()
                  : text == "freiburg1" ? DepthIntrinsics::freiburg1()
                  : text == "freiburg2" ? DepthIntrinsics::freiburg2()
                                        : DepthIntrinsics::freiburg3();
    intrinsics->units_per_metre = units;
    return true;
  }
  std::vector<double> values;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v)) {
      *error = "camera '" + text + "': '" + item + "' is not a number";
      return false;
    }
    values.push_back(v);
  }
  if (values.size() != 4 && values.size() != 9) {
    *error = "camera '" + text + "': not tum, freiburg1, freiburg2, freiburg3, \"fx,fy,cx,cy\" or \"fx,fy,cx,cy,k1,k2,p1,p2,k3\"";
    return false;
  }
  if (!(values[0] > 0.0 && values[1] > 0.0)) {
    *error = "camera '" + text + "': the focal lengths must be > 0";
    return false;
  }
  DepthIntrinsics k;
  k.fx = values[0], k.fy = values[1], k.cx = values[2], k.cy = values[3];
  if (values.size() == 9) k.k1 = values[4], k.k2 = values[5], k.p1 = values[6], k.p2 = values[7], k.k3 = values[8];
  k.units_per_metre = units;
  *intrinsics = k;
  return true;
}

namespace {

// The plumb-bob model's two parts at an undistorted ray: distorted = radial * ray + tangential.
void lensTerms(const Eigen::Vector2d& ray, const DepthIntrinsics& k, double* radial, Eigen::Vector2d* tangential) {
  const double x = ray.x(), y = ray.y(), r2 = x * x + y * y;
  *radial = 1.0 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  *tangential = {2.0 * k.p1 * x * y + k.p2 * (r2 + 2.0 * x * x), k.p1 * (r2 + 2.0 * y * y) + 2.0 * k.p2 * x * y};
}

}  // namespace

Eigen::Vector2d distortRay(const Eigen::Vector2d& ray, const DepthIntrinsics& k) {
  double radial;
  Eigen::Vector2d tangential;
  lensTerms(ray, k, &radial, &tangential);
  return ray * radial + tangential;
}

Eigen::Vector2d undistortRay(const Eigen::Vector2d& distorted, const DepthIntrinsics& k) {
  Eigen::Vector2d ray = distorted;
  for (int round = 0; round < 100; ++round) {
    double radial;
    Eigen::Vector2d tangential;
    lensTerms(ray, k, &radial, &tangential);
    const Eigen::Vector2d next = (distorted - tangential) / radial;
    const bool settled = (next - ray).norm() < 1e-12;
    ray = next;
    if (settled) break;
  }
  return ray;
}

namespace {

// Each pixel's undistorted ray (x, y), row by row; worked out once per camera and image size (a
// sequence's frames share them).
const std::vector<Eigen::Vector2d>& raysOf(int width, int height, const DepthIntrinsics& k) {
  thread_local std::vector<Eigen::Vector2d> rays;
  thread_local int rays_width = -1, rays_height = -1;
  thread_local DepthIntrinsics rays_of;
  const auto same = [](const DepthIntrinsics& a, const DepthIntrinsics& b) {
    return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 &&
           a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3;
  };
  if (rays_width == width && rays_height == height && same(rays_of, k)) return rays;
  rays.resize(std::size_t(width) * height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector2d pinhole((u - k.cx) / k.fx, (v - k.cy) / k.fy);
      rays[std::size_t(v) * width + u] = k.distorted() ? undistortRay(pinhole, k) : pinhole;
    }
  }
  rays_width = width, rays_height = height, rays_of = k;
  return rays;
}

}  // namespace

std::vector<Eigen::Vector3f> depthPoints(int width, int height, const std::vector<std::uint16_t>& pixels,
                                         const DepthIntrinsics& k) {
  std::vector<Eigen::Vector3f> points(std::size_t(width) * height);
  const std::vector<Eigen::Vector2d>& rays = raysOf(width, height, k);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (pixels[i] == 0) {
      points[i] = Eigen::Vector3f(nan, nan, nan);
      continue;
    }
    const double d = pixels[i] / k.units_per_metre;
    points[i] = Eigen::Vector3f(float(rays[i].x() * d), float(rays[i].y() * d), float(d));
  }
  return points;
}

}  // namespace tools
}  // namespace octo_slice_mapper
