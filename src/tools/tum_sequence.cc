#include "tum_sequence.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
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

std::vector<Eigen::Vector3f> depthPoints(int width, int height, const std::vector<std::uint16_t>& pixels,
                                         const DepthIntrinsics& k) {
  std::vector<Eigen::Vector3f> points(std::size_t(width) * height);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = std::size_t(v) * width + u;
      if (pixels[i] == 0) {
        points[i] = Eigen::Vector3f(nan, nan, nan);
        continue;
      }
      const double d = pixels[i] / k.units_per_metre;
      points[i] = Eigen::Vector3f(float((u - k.cx) * d / k.fx), float((v - k.cy) * d / k.fy), float(d));
    }
  }
  return points;
}

}  // namespace tools
}  // namespace octo_slice_mapper
