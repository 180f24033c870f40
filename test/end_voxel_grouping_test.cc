#include "core/internal/end_voxel_grouping.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cfloat>
#include <cmath>
#include <limits>
#include <map>
#include <random>

namespace osm = octo_slice_mapper;

namespace {

constexpr double kResolution = 0.05;
constexpr unsigned kDepth = 16;
const double kInverse = 1.0 / kResolution;
const double kCentre = 32768.0;

// Floats where the key's arithmetic has its edges: voxel boundaries and the floats beside them,
// the octree's key range, signed zeros, denormals, the largest floats, infinities and NaNs.
// (At a power-of-two resolution the key range's upper end is a float itself.)
std::vector<float> edgeFloats(double resolution) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> v = {0.0f, -0.0f, FLT_MIN, -FLT_MIN, FLT_TRUE_MIN, -FLT_TRUE_MIN, FLT_MAX, -FLT_MAX,
                          inf,  -inf,  nan,     -nan,     1e6f,         -1e6f};
  const float range = static_cast<float>(kCentre * resolution);  // where the keys end: 1638.4 m at 0.05 m
  for (float edge : {range, -range}) {
    for (float f : {edge, std::nextafter(edge, 0.0f), std::nextafter(edge, 2 * edge)}) v.push_back(f);
  }
  for (int k = -60; k <= 60; ++k) {
    const float boundary = static_cast<float>(k * resolution);
    v.push_back(boundary);
    v.push_back(std::nextafter(boundary, inf));
    v.push_back(std::nextafter(boundary, -inf));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> wide(-2000.0f, 2000.0f), near(-5.0f, 5.0f);
  for (int i = 0; i < 2000; ++i) v.push_back(i % 2 ? wide(rng) : near(rng));
  return v;
}

}  // namespace

TEST(EndVoxelGrouping, KeyCoordinateIsTheScaledCoordinateTruncatedWhereThereIsOne) {
  EXPECT_EQ(osm::keyCoordinateOf(std::numeric_limits<float>::quiet_NaN(), kInverse, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(std::numeric_limits<float>::infinity(), kInverse, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(-std::numeric_limits<float>::infinity(), kInverse, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(1e6f, kInverse, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(-1e6f, kInverse, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(-0.0f, kInverse, kCentre), 32768);
  EXPECT_EQ(osm::keyCoordinateOf(-0.01f, kInverse, kCentre), 32767);  // below 0: the voxel below
  // Away from the rounding at a boundary, OctoMap's own key.
  octomap::OcTree tree(kResolution);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> any(-50.0, 50.0);
  for (int i = 0; i < 10000; ++i) {
    const float c = static_cast<float>(any(rng));
    const double cells = double(c) / kResolution;
    if (std::abs(cells - std::round(cells)) < 1e-6) continue;
    EXPECT_EQ(osm::keyCoordinateOf(c, kInverse, kCentre), static_cast<std::int32_t>(tree.coordToKey(double(c)))) << c;
  }
}

// The SIMD path against the one-coordinate reference, value for value, at every alignment and
// with counts that leave a remainder.
TEST(EndVoxelGrouping, KeyCoordinatesAreKeyCoordinateOfForEveryValue) {
  for (const auto key_coordinates : {osm::keyCoordinates}) {
    for (double resolution : {kResolution, 0.0625}) {
      const double inverse = 1.0 / resolution;
      const std::vector<float> values = edgeFloats(resolution);
      for (std::size_t offset = 0; offset < 4; ++offset) {
        for (std::size_t count : {values.size() - offset, std::size_t{1}, std::size_t{3}, std::size_t{5}}) {
          std::vector<std::int32_t> keys(count, 12345);
          key_coordinates(values.data() + offset, count, inverse, kCentre, keys.data());
          for (std::size_t k = 0; k < count; ++k) {
            ASSERT_EQ(keys[k], osm::keyCoordinateOf(values[offset + k], inverse, kCentre))
                << "value " << values[offset + k] << " at " << k << " of " << count << ", offset " << offset
                << ", resolution " << resolution;
          }
        }
      }
    }
  }
  // The upper end of the keys is outside.
  EXPECT_EQ(osm::keyCoordinateOf(2048.0f, 16.0, kCentre), osm::kNoKeyCoordinate);
  EXPECT_EQ(osm::keyCoordinateOf(std::nextafter(2048.0f, 0.0f), 16.0, kCentre), 65535);
}

// A frame with NaN borders, infinite and far points, grouped on one and on two threads, against
// a plain map from key to sum and count built point by point.
TEST(EndVoxelGrouping, GroupsAreThePointsOfEachVoxelOnAnyNumberOfThreads) {
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  std::vector<Eigen::Vector3f> points;
  std::size_t nan = 0, inf = 0;
  std::vector<Eigen::Vector3d> outside;
  const float kNaN = std::numeric_limits<float>::quiet_NaN(), kInf = std::numeric_limits<float>::infinity();
  for (int row = 0; row < 240; ++row) {
    for (int col = 0; col < 320; ++col) {
      Eigen::Vector3f p(2.0f + 0.01f * col + noise(rng), -1.0f + 0.01f * row + noise(rng), 0.3f + noise(rng));
      if (col < 8 || row < 4) p.x() = kNaN, ++nan;  // the border
      else if ((row * 320 + col) % 997 == 0) p.z() = -kInf, ++inf;
      else if ((row * 320 + col) % 991 == 0) p.y() = kNaN, p.z() = kInf, ++nan;  // NaN counts first
      else if ((row * 320 + col) % 983 == 0) p.x() = 5000.0f, outside.push_back(p.cast<double>());
      points.push_back(p);
    }
  }
  struct Sum {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::uint64_t n = 0;
  };
  std::map<std::uint64_t, Sum> expected;
  for (const Eigen::Vector3f& p : points) {
    std::int32_t k[3];
    for (int d = 0; d < 3; ++d) k[d] = osm::keyCoordinateOf(p[d], kInverse, kCentre);
    if (k[0] < 0 || k[1] < 0 || k[2] < 0) continue;
    Sum& s = expected[std::uint64_t(k[0]) | std::uint64_t(k[1]) << 16 | std::uint64_t(k[2]) << 32];
    s.sum += p.cast<double>();
    ++s.n;
  }
  const Eigen::Vector3f reference(3.0f, 0.0f, 1.0f);  // a sensor's origin near the points
  const osm::EndVoxels one = osm::groupByEndVoxel(points, kResolution, kDepth, 1, reference);
  const osm::EndVoxels two = osm::groupByEndVoxel(points, kResolution, kDepth, 2, reference);
  for (const osm::EndVoxels* g : {&one, &two}) {
    EXPECT_EQ(g->non_finite[osm::ReadingKind::kNaN], nan);
    EXPECT_EQ(g->non_finite[osm::ReadingKind::kInfinite], inf);
    EXPECT_EQ(g->outside, outside);
    ASSERT_EQ(g->voxels.size(), expected.size());
    for (const osm::EndVoxel& v : g->voxels) {
      const auto it = expected.find(v.key);
      ASSERT_NE(it, expected.end()) << v.key;
      EXPECT_EQ(v.n, it->second.n);
      // Float sums of offsets within 2.5 m of the reference: each addition rounds by at most
      // half an ulp of a sum of n of them.
      const double n = static_cast<double>(it->second.n);
      EXPECT_LE((v.sum - it->second.sum).norm(), (n + 1) * (n + 1) * 2.5 * std::ldexp(1.0, -24)) << n;
    }
  }
  // The same groups in the same order with the same sums, bit for bit, on either number of threads.
  ASSERT_EQ(one.voxels.size(), two.voxels.size());
  for (std::size_t i = 0; i < one.voxels.size(); ++i) {
    EXPECT_EQ(one.voxels[i].key, two.voxels[i].key);
    EXPECT_EQ(one.voxels[i].sum, two.voxels[i].sum);
  }
}

// Far from the map's origin (a building 1.5 km out) the sums are as good as near it: they are
// offsets from the reference. Each mean lies in its voxel. (About 80 points a voxel.)
TEST(EndVoxelGrouping, MeansAreGoodFarFromTheOriginAndInsideTheirVoxel) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> spread(-0.2f, 0.2f);
  const Eigen::Vector3d sensor(1500.3, -1200.0, 1.0);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 40000; ++i) {
    Eigen::Vector3f p = (sensor + Eigen::Vector3d(spread(rng), spread(rng), spread(rng))).cast<float>();
    points.push_back(p);
  }
  const osm::EndVoxels g = osm::groupByEndVoxel(points, kResolution, kDepth, 2, sensor.cast<float>());
  std::map<std::uint64_t, std::pair<Eigen::Vector3d, std::uint64_t>> exact;
  for (const Eigen::Vector3f& p : points) {
    std::int32_t k[3];
    for (int d = 0; d < 3; ++d) k[d] = osm::keyCoordinateOf(p[d], kInverse, kCentre);
    auto& e = exact.try_emplace(std::uint64_t(k[0]) | std::uint64_t(k[1]) << 16 | std::uint64_t(k[2]) << 32,
                                Eigen::Vector3d::Zero(), 0)
                  .first->second;
    e.first += p.cast<double>();
    ++e.second;
  }
  octomap::OcTree tree(kResolution);
  ASSERT_EQ(g.voxels.size(), exact.size());
  for (const osm::EndVoxel& v : g.voxels) {
    const auto& e = exact.at(v.key);
    ASSERT_EQ(v.n, e.second);
    const Eigen::Vector3d mean = osm::meanInVoxel(v, kResolution, kDepth);
    EXPECT_LT((mean - e.first / double(e.second)).norm(), 1e-5) << v.n;
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(std::uint64_t(tree.coordToKey(mean[d])), (v.key >> (16 * d)) & 0xffff) << "axis " << d << " mean " << mean[d];
    }
  }
}

// Every point is read within its array, the last one too, at every count around the pieces'
// boundaries (a sanitized build catches a read past the end: the arrays are exactly their size).
TEST(EndVoxelGrouping, EveryCountOfPointsIsSummedWithinItsArray) {
  for (std::size_t count : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{5}, std::size_t{16383},
                            std::size_t{16384}, std::size_t{16385}, std::size_t{3 * 16384 + 1}}) {
    std::vector<Eigen::Vector3f> points(count);
    for (std::size_t i = 0; i < count; ++i) points[i] = Eigen::Vector3f(0.01f * float(i % 97), 0.5f, 0.001f * float(i % 13));
    points.shrink_to_fit();
    for (unsigned threads : {1u, 2u}) {
      const osm::EndVoxels g = osm::groupByEndVoxel(points, kResolution, kDepth, threads, Eigen::Vector3f(0.5f, 0.5f, 0.0f));
      std::uint64_t n = 0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const osm::EndVoxel& v : g.voxels) n += v.n, sum += v.sum;
      EXPECT_EQ(n, count);
      Eigen::Vector3d exact = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3f& p : points) exact += p.cast<double>();
      EXPECT_LT((sum - exact).norm(), 1e-6 * double(count)) << count;
    }
  }
}

// Points on and just above a voxel face (a simulated floor at z = 0, a wall on a voxel boundary):
// their sums' rounding may put the mean just below the face, and the mean is then moved back in.
TEST(EndVoxelGrouping, MeansLieInTheirVoxelWhenTheirPointsLieOnAFace) {
  octomap::OcTree tree(kResolution);
  std::size_t voxels = 0;
  for (float sensor_z : {0.3f, 1.7f, 2.9f}) {
    std::vector<Eigen::Vector3f> points;
    for (int i = 0; i < 60000; ++i) {
      // 0 and the floats just above it, 0.03 m x 0.03 m across: one voxel per cell.
      points.emplace_back(0.001f * float(i % 30), 0.001f * float((i / 30) % 30) + 0.05f * float(i / 900),
                          (i % 7) * 1e-9f);
    }
    const osm::EndVoxels g = osm::groupByEndVoxel(points, kResolution, kDepth, 1, Eigen::Vector3f(1.3f, -0.7f, sensor_z));
    for (const osm::EndVoxel& v : g.voxels) {
      const Eigen::Vector3d mean = osm::meanInVoxel(v, kResolution, kDepth);
      ++voxels;
      for (int d = 0; d < 3; ++d) {
        ASSERT_EQ(std::uint64_t(tree.coordToKey(mean[d])), (v.key >> (16 * d)) & 0xffff)
            << "axis " << d << " mean " << mean[d] << ", sensor at z " << sensor_z;
      }
    }
  }
  EXPECT_GT(voxels, 100u);
}
