#include "ros/point_cloud_conversion.h"

#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif
#include <limits>

namespace octo_slice_mapper {
namespace ros_adapter {
namespace {

const sensor_msgs::PointField* fieldNamed(const sensor_msgs::PointCloud2& msg, const char* name) {
  for (const sensor_msgs::PointField& f : msg.fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

std::size_t bytesOf(std::uint8_t datatype) {
  switch (datatype) {
    case sensor_msgs::PointField::FLOAT32:
      return 4;
    case sensor_msgs::PointField::FLOAT64:
      return 8;
    default:
      return 0;  // not a coordinate type
  }
}

float coordinate(const std::uint8_t* point, const sensor_msgs::PointField& f) {
  if (f.datatype == sensor_msgs::PointField::FLOAT64) {
    double v;
    std::memcpy(&v, point + f.offset, sizeof v);
    return static_cast<float>(v);
  }
  float v;
  std::memcpy(&v, point + f.offset, sizeof v);
  return v;
}

bool hostIsBigEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 0;
}

}  // namespace

ScanRejection checkCloudLayout(const sensor_msgs::PointCloud2& msg) {
  for (const char* name : {"x", "y", "z"}) {
    const sensor_msgs::PointField* f = fieldNamed(msg, name);
    if (!f) return {"cloud_bad_fields", std::string("no '") + name + "' field"};
    const std::size_t size = bytesOf(f->datatype);
    if (size == 0 || f->count < 1) {
      return {"cloud_bad_fields", std::string("field '") + name + "' is not a FLOAT32 or FLOAT64 scalar"};
    }
    if (std::size_t(f->offset) + size > msg.point_step) {
      return {"cloud_bad_layout", std::string("field '") + name + "' (offset " + std::to_string(f->offset) +
                                      ") does not fit in point_step " + std::to_string(msg.point_step)};
    }
  }
  if (bool(msg.is_bigendian) != hostIsBigEndian()) return {"cloud_big_endian", "byte order differs from this host's"};
  const std::uint64_t points = std::uint64_t(msg.width) * msg.height;
  if (points == 0) return {"cloud_empty", "no points (width " + std::to_string(msg.width) + ", height " +
                                              std::to_string(msg.height) + ")"};
  if (points > kMaxPointsPerCloud) {
    return {"cloud_too_large", std::to_string(points) + " points (at most " + std::to_string(kMaxPointsPerCloud) + ")"};
  }
  if (std::uint64_t(msg.row_step) < std::uint64_t(msg.width) * msg.point_step) {
    return {"cloud_bad_layout", "row_step " + std::to_string(msg.row_step) + " is shorter than width x point_step " +
                                    std::to_string(std::uint64_t(msg.width) * msg.point_step)};
  }
  const std::uint64_t needed = std::uint64_t(msg.row_step) * msg.height;
  if (msg.data.size() < needed) {
    return {"cloud_short_data", std::to_string(msg.data.size()) + " bytes of data for " + std::to_string(points) +
                                    " points declared (" + std::to_string(needed) + " bytes)"};
  }
  return {};
}

namespace {

// The message is read once, front to back, and is larger than a core's caches: its lines are
// asked for 2 KB ahead, which takes about a quarter off a room frame's conversion. A prefetch past
// the data's end is dropped, never a fault; the address is made as an integer, not as a pointer
// past the array.
inline void prefetchAhead(const std::uint8_t* p) {
  constexpr std::uintptr_t kAhead = 2048;
  __builtin_prefetch(reinterpret_cast<const void*>(reinterpret_cast<std::uintptr_t>(p) + kAhead));
}

// One point: written at `out` in the map frame if finite (returns the next place), else counted.
// The rotation and translation apart: Eigen's Isometry3f product took a third more time (and
// rounds some coordinates differently in the last bit).
inline Eigen::Vector3f* transformOne(const Eigen::Vector3f& v, const Eigen::Matrix3f& rotation,
                                     const Eigen::Vector3f& translation, Eigen::Vector3f* out,
                                     ReadingCounts* left_out) {
  // An organized frame's NaN pixels come in runs (its borders, what the camera can't see): the
  // branch is predicted, and the grouping never sees them.
  if (v.allFinite()) {
    *out++ = rotation * v + translation;
  } else {
    (*left_out)[nonFiniteKind(v)]++;
  }
  return out;
}

// The finite points of rows [row0, row1) read with `read(point_bytes)`, in the map frame, in
// order from `out` on; the others counted. Returns the end of the points written. With `ranges`
// (one float per point of a single row: row1 = row0 + 1), each point's distance from the sensor
// (its coordinates' norm; NaN or infinite for a non-finite point) is written there too.
template <typename Read>
Eigen::Vector3f* transformPoints(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3f& to_map, Read read,
                                 Eigen::Vector3f* out, ReadingCounts* left_out, std::uint32_t row0, std::uint32_t row1,
                                 float* ranges) {
  const Eigen::Matrix3f rotation = to_map.linear();
  const Eigen::Vector3f translation = to_map.translation();
  for (std::uint32_t row = row0; row < row1; ++row) {
    const std::uint8_t* p = msg.data.data() + std::size_t(row) * msg.row_step;
    for (std::uint32_t col = 0; col < msg.width; ++col, p += msg.point_step) {
      prefetchAhead(p);
      const Eigen::Vector3f v = read(p);
      if (ranges) ranges[col] = std::sqrt(v.x() * v.x() + v.y() * v.y() + v.z() * v.z());
      out = transformOne(v, rotation, translation, out, left_out);
    }
  }
  return out;
}

#if defined(__SSE2__)
// transformPoints for the layout depth cameras send (FLOAT32 x, y, z at bytes 0, 4, 8 of a
// 16-byte point), four points at a time where all four are finite: each coordinate is
// (r0 x + (r1 y + r2 z)) + t, the products and sums of Eigen's `rotation * v + translation` in
// its order (its sum of three terms splits them in halves; x86-64's baseline has no fused
// multiply-add), so the same floats
// (PointCloudConversion.PointsAreTheRotationAndTranslationToTheBit). Eigen's product of one point
// took ~33 instructions, a third of them shuffles.
// Rows [row0, row1) and `ranges` as transformPoints'.
Eigen::Vector3f* transformXyzIn16Bytes(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3f& to_map,
                                       Eigen::Vector3f* out, ReadingCounts* left_out, std::uint32_t row0,
                                       std::uint32_t row1, float* ranges) {
  const Eigen::Matrix3f rotation = to_map.linear();
  const Eigen::Vector3f translation = to_map.translation();
  __m128 r[3][3], t[3];
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) r[i][k] = _mm_set1_ps(rotation(i, k));
    t[i] = _mm_set1_ps(translation[i]);
  }
  const auto one = [&](const std::uint8_t* p) {
    float c[3];
    std::memcpy(c, p, sizeof c);
    out = transformOne(Eigen::Vector3f(c[0], c[1], c[2]), rotation, translation, out, left_out);
  };
  const auto rangeOf = [](const std::uint8_t* p) {
    float c[3];
    std::memcpy(c, p, sizeof c);
    return std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
  };
  const std::uint32_t width = msg.width;
  std::uint64_t nans = 0, non_finite = 0;  // in groups of four without a finite point
  for (std::uint32_t row = row0; row < row1; ++row) {
    const std::uint8_t* p = msg.data.data() + std::size_t(row) * msg.row_step;
    std::uint32_t col = 0;
    for (; col + 4 <= width; col += 4, p += 64) {
      prefetchAhead(p);
      const float* f = reinterpret_cast<const float*>(p);
      __m128 x = _mm_loadu_ps(f), y = _mm_loadu_ps(f + 4), z = _mm_loadu_ps(f + 8), w = _mm_loadu_ps(f + 12);
      _MM_TRANSPOSE4_PS(x, y, z, w);  // the four points' x, y and z
      if (ranges) {  // std::sqrt's rounding, (x x + y y) + z z as the scalar sum
        _mm_storeu_ps(ranges + col,
                      _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z))));
      }
      // v - v is NaN for a NaN or infinite v.
      const __m128 finite = _mm_and_ps(_mm_cmpord_ps(_mm_sub_ps(x, x), _mm_sub_ps(y, y)),
                                       _mm_cmpord_ps(_mm_sub_ps(z, z), _mm_sub_ps(z, z)));
      const int finite_lanes = _mm_movemask_ps(finite);
      if (finite_lanes == 0) {  // inside an organized frame's runs of NaN: counted four at a time
        const __m128 nan = _mm_or_ps(_mm_or_ps(_mm_cmpunord_ps(x, x), _mm_cmpunord_ps(y, y)), _mm_cmpunord_ps(z, z));
        // (A table: without -mpopcnt, __builtin_popcount is a library call.)
        static constexpr std::uint8_t kLanes[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
        nans += kLanes[_mm_movemask_ps(nan)];
        non_finite += 4;
        continue;
      }
      if (finite_lanes != 0xF) {  // a run's edge
        for (int k = 0; k < 4; ++k) one(p + 16 * k);
        continue;
      }
      // Row by row, written out: as a loop over the rows GCC kept the loop and took each row's
      // result through memory (a fifth more instructions for the whole conversion).
      const auto row = [&](int i) {
        const __m128 yz = _mm_add_ps(_mm_mul_ps(r[i][1], y), _mm_mul_ps(r[i][2], z));
        return _mm_add_ps(_mm_add_ps(_mm_mul_ps(r[i][0], x), yz), t[i]);
      };
      __m128 m0 = row(0), m1 = row(1), m2 = row(2), last = _mm_setzero_ps();
      _MM_TRANSPOSE4_PS(m0, m1, m2, last);  // back to points: x, y, z and a zero each
      float* o = out->data();
      _mm_storeu_ps(o, m0);  // each store's fourth float is the next point's x
      _mm_storeu_ps(o + 3, m1);
      _mm_storeu_ps(o + 6, m2);
      _mm_storel_pi(reinterpret_cast<__m64*>(o + 9), last);
      _mm_store_ss(o + 11, _mm_movehl_ps(last, last));
      out += 4;
    }
    for (; col < width; ++col, p += 16) {
      if (ranges) ranges[col] = rangeOf(p);
      one(p);
    }
  }
  (*left_out)[ReadingKind::kNaN] += nans;
  (*left_out)[ReadingKind::kInfinite] += non_finite - nans;
  return out;
}
#endif

}  // namespace

void cloudPointsInMap(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3f& to_map,
                      std::vector<Eigen::Vector3f>* points, ReadingCounts* left_out,
                      const FlyingPixelOptions* flying) {
  const sensor_msgs::PointField& fx = *fieldNamed(msg, "x");
  const sensor_msgs::PointField& fy = *fieldNamed(msg, "y");
  const sensor_msgs::PointField& fz = *fieldNamed(msg, "z");
  points->resize(std::size_t(msg.width) * msg.height);
  const bool all_float = fx.datatype == sensor_msgs::PointField::FLOAT32 &&
                         fy.datatype == sensor_msgs::PointField::FLOAT32 && fz.datatype == sensor_msgs::PointField::FLOAT32;
  const bool xyz16 = all_float && fx.offset == 0 && fy.offset == 4 && fz.offset == 8 && msg.point_step == 16;
  // The transform of rows [row0, row1), its points written from `out` on (and with `ranges`, one
  // row's ranges).
  const auto transformRows = [&](std::uint32_t row0, std::uint32_t row1, float* ranges,
                                 Eigen::Vector3f* out) -> Eigen::Vector3f* {
#if defined(__SSE2__)
    if (xyz16) return transformXyzIn16Bytes(msg, to_map, out, left_out, row0, row1, ranges);
#endif
    if (all_float) {  // what cameras send: no per-coordinate type test (a third of the conversion)
      const std::uint32_t ox = fx.offset, oy = fy.offset, oz = fz.offset;
      return transformPoints(msg, to_map, [ox, oy, oz](const std::uint8_t* p) {
        float x, y, z;
        std::memcpy(&x, p + ox, sizeof x);
        std::memcpy(&y, p + oy, sizeof y);
        std::memcpy(&z, p + oz, sizeof z);
        return Eigen::Vector3f(x, y, z);
      }, out, left_out, row0, row1, ranges);
    }
    return transformPoints(msg, to_map, [&](const std::uint8_t* p) {
      return Eigen::Vector3f(coordinate(p, fx), coordinate(p, fy), coordinate(p, fz));
    }, out, left_out, row0, row1, ranges);
  };
  if (!flying || !flying->enabled || msg.height < 3 || msg.width < 3) {
    Eigen::Vector3f* end = transformRows(0, msg.height, nullptr, points->data());
    points->resize(static_cast<std::size_t>(end - points->data()));
    return;
  }
  // An organized frame's flying pixels, in the same pass: each row is moved with its ranges kept
  // (three rows of them, per thread), and once the row below it is, the row before is judged and
  // its flying pixels taken out of the points it wrote (rare: the row's and the next row's points
  // move up).
  const std::uint32_t width = msg.width;
  thread_local std::vector<float> rows;
  thread_local std::vector<std::uint8_t> flags;
  rows.resize(3 * std::size_t(width));
  flags.resize(width);
  const auto slot = [&](std::uint32_t row) { return &rows[std::size_t(row % 3) * width]; };
  // Whether a point was written (the transform's test: its coordinates are finite), read from its
  // range where that tells: a finite range has finite coordinates, a NaN one a NaN coordinate;
  // only an infinite range (an infinite coordinate, or finite ones whose squares overflow) is
  // tested on the coordinates as the transform reads them.
  const auto written = [&](std::uint32_t row, std::uint32_t col, float range) {
    if (std::isfinite(range)) return true;
    if (std::isnan(range)) return false;
    const std::uint8_t* p = msg.data.data() + std::size_t(row) * msg.row_step + std::size_t(col) * msg.point_step;
    return Eigen::Vector3f(coordinate(p, fx), coordinate(p, fy), coordinate(p, fz)).allFinite();
  };
  Eigen::Vector3f* end = points->data();
  Eigen::Vector3f* previous_start = end;  // where the row before this one's points begin
  std::uint64_t flying_count = 0;
  for (std::uint32_t row = 0; row < msg.height; ++row) {
    Eigen::Vector3f* start = end;
    end = transformRows(row, row + 1, slot(row), end);
    if (row < 2) {  // the first row is kept (a border row)
      previous_start = start;
      continue;
    }
    if (flagFlyingRow(slot(row - 2), slot(row - 1), slot(row), int(width), *flying, flags.data())) {
      Eigen::Vector3f* kept = previous_start;
      Eigen::Vector3f* read = previous_start;
      const float* ranges = slot(row - 1);
      for (std::uint32_t col = 0; col < width; ++col) {
        if (!written(row - 1, col, ranges[col])) continue;  // counted by the transform already
        if (flags[col]) ++flying_count;
        else *kept++ = *read;
        ++read;
      }
      std::memmove(static_cast<void*>(kept), start, static_cast<std::size_t>(end - start) * sizeof(Eigen::Vector3f));
      end = kept + (end - start);
      start = kept;
    }
    previous_start = start;
  }
  (*left_out)[ReadingKind::kFlyingPixel] += flying_count;
  points->resize(static_cast<std::size_t>(end - points->data()));
}

ScanRejection toCoreCloud(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3d& sensor_pose, SensorCloud* out) {
  // Checked before a single byte is read: a layout that declares more than the message holds
  // must not reach a converter that trusts it.
  const ScanRejection rejection = checkCloudLayout(msg);
  if (rejection.rejected()) return rejection;
  out->origin = sensor_pose.translation();
  out->left_out = ReadingCounts{};
  cloudPointsInMap(msg, sensor_pose.cast<float>(), &out->points, &out->left_out);
  return rejection;
}

ScanRejection toDeferredCloud(const sensor_msgs::PointCloud2::ConstPtr& msg, const Eigen::Isometry3d& sensor_pose,
                              DeferredCloud* out) {
  const ScanRejection rejection = checkCloudLayout(*msg);
  if (rejection.rejected()) return rejection;
  out->origin = sensor_pose.translation();
  out->points = [msg, to_map = Eigen::Isometry3f(sensor_pose.cast<float>())](
                    std::vector<Eigen::Vector3f>* points, ReadingCounts* left_out, const FlyingPixelOptions& flying) {
    cloudPointsInMap(*msg, to_map, points, left_out, &flying);
  };
  return rejection;
}

sensor_msgs::PointCloud2 organizedCloud(const std::vector<Eigen::Vector3f>& points, int width, int height,
                                        const std::string& frame_id) {
  sensor_msgs::PointCloud2 msg;
  msg.header.frame_id = frame_id;
  sensor_msgs::PointCloud2Modifier modifier(msg);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  modifier.resize(std::size_t(width) * height);
  msg.width = static_cast<std::uint32_t>(width);
  msg.height = static_cast<std::uint32_t>(height);
  msg.row_step = msg.point_step * msg.width;
  msg.is_dense = false;
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), y(msg, "y"), z(msg, "z");
  for (std::size_t k = 0; k < points.size() && k < std::size_t(width) * height; ++k, ++x, ++y, ++z) {
    *x = points[k].x(), *y = points[k].y(), *z = points[k].z();
  }
  return msg;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
