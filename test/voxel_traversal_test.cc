// The one grid walk (voxel_traversal.h) against a brute-force reference: every cell of the
// segment's bounding box cut with the segment (slab by slab), those it crosses for a positive
// length sorted by where it enters them. Same cells, same order, same exit distances.
#include "core/internal/voxel_traversal.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>
#include <random>
#include <vector>

using namespace octo_slice_mapper;

namespace {

struct Crossed {
  std::array<int, 3> cell;
  double t_exit;  // fraction of the segment where it leaves the cell (beyond 1 for the last)
};

// The cells of a grid (cell c spans [c * size, (c + 1) * size) per axis) that the segment from `a`
// to `b` crosses for a positive length, by entry. dims: 2 or 3 (z ignored in 2D).
std::vector<Crossed> bruteForce(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double size, int dims) {
  int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (int d = 0; d < dims; ++d) {
    lo[d] = int(std::floor(std::min(a[d], b[d]) / size)) - 1;
    hi[d] = int(std::floor(std::max(a[d], b[d]) / size)) + 1;
  }
  struct Hit {
    double t_in;
    Crossed c;
  };
  std::vector<Hit> hits;
  for (int i = lo[0]; i <= hi[0]; ++i) {
    for (int j = lo[1]; j <= hi[1]; ++j) {
      for (int k = lo[2]; k <= hi[2]; ++k) {
        const int cell[3] = {i, j, k};
        double t_in = -1e300, t_out = 1e300;
        bool inside = true;
        for (int d = 0; d < dims; ++d) {
          const double c0 = cell[d] * size, c1 = c0 + size, delta = b[d] - a[d];
          if (delta == 0.0) {
            inside = inside && a[d] >= c0 && a[d] < c1;
            continue;
          }
          const double s0 = (c0 - a[d]) / delta, s1 = (c1 - a[d]) / delta;
          t_in = std::max(t_in, std::min(s0, s1));
          t_out = std::min(t_out, std::max(s0, s1));
        }
        // Crossed within the segment, for more than a rounding's length.
        if (!inside || std::min(t_out, 1.0) - std::max(t_in, 0.0) <= 1e-9) continue;
        hits.push_back({std::max(t_in, 0.0), {{i, j, dims == 3 ? k : 0}, t_out}});
      }
    }
  }
  std::sort(hits.begin(), hits.end(), [](const Hit& x, const Hit& y) { return x.t_in < y.t_in; });
  std::vector<Crossed> out;
  for (const Hit& h : hits) out.push_back(h.c);
  return out;
}

void expectSameWalk(const std::vector<Crossed>& reference, const std::vector<Crossed>& walked, const char* what) {
  ASSERT_EQ(reference.size(), walked.size()) << what;
  for (std::size_t n = 0; n < reference.size(); ++n) {
    EXPECT_EQ(reference[n].cell, walked[n].cell) << what << ", cell " << n;
    EXPECT_NEAR(reference[n].t_exit, walked[n].t_exit, 1e-9 * std::max(1.0, std::abs(reference[n].t_exit)))
        << what << ", cell " << n;
  }
}

class VoxelTraversalTest : public ::testing::Test {
 protected:
  octomap::OcTree tree{0.05};
  std::mt19937 rng{11};
  std::uniform_real_distribution<double> coordinate{-1.5, 1.5};
  // OctoMap's keys are the cells of a grid shifted by the tree's centre key.
  int centre() const { return 1 << (tree.getTreeDepth() - 1); }
  std::vector<Crossed> walkOctree(const Eigen::Vector3d& a, const Eigen::Vector3d& b, bool level) {
    octomap::OcTreeKey ka, kb;
    EXPECT_TRUE(tree.coordToKeyChecked(a.x(), a.y(), a.z(), ka));
    EXPECT_TRUE(tree.coordToKeyChecked(b.x(), b.y(), b.z(), kb));
    std::vector<Crossed> out;
    const auto visit = [&](std::uint64_t p, double t_exit) {
      const octomap::OcTreeKey k = PackedKeys::keyOf(p);
      out.push_back({{int(k[0]) - centre(), int(k[1]) - centre(), level ? 0 : int(k[2]) - centre()}, t_exit});
    };
    traverseVoxels(tree, a, b, ka, kb, PackedKeys{}, visit);
    return out;
  }
  Eigen::Vector3d randomPoint() { return {coordinate(rng), coordinate(rng), coordinate(rng)}; }
};

TEST_F(VoxelTraversalTest, VoxelsOfSlantedSegmentsMatchBruteForce) {
  for (int n = 0; n < 400; ++n) {
    const Eigen::Vector3d a = randomPoint(), b = n % 2 ? randomPoint() : a + 0.1 * (randomPoint() - a);
    expectSameWalk(bruteForce(a, b, tree.getResolution(), 3), walkOctree(a, b, false), "3D segment");
  }
}

TEST_F(VoxelTraversalTest, NearlyLevelSegmentsChangeLayerWhereTheyCrossIt) {
  // A tilted scan's ray: 1 degree off the horizontal over 3 m crosses one or two layers.
  for (int n = 0; n < 200; ++n) {
    const Eigen::Vector3d a = randomPoint();
    const double yaw = coordinate(rng) * 2.0, pitch = 0.0175 * coordinate(rng) / 1.5;
    const Eigen::Vector3d b = a + 3.0 * Eigen::Vector3d(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                                                        std::sin(pitch));
    expectSameWalk(bruteForce(a, b, tree.getResolution(), 3), walkOctree(a, b, false), "nearly level segment");
  }
}

TEST_F(VoxelTraversalTest, LevelSegmentsStayInTheirLayer) {
  for (int n = 0; n < 400; ++n) {
    const Eigen::Vector3d a = randomPoint();
    Eigen::Vector3d b = randomPoint();
    b.z() = a.z();
    expectSameWalk(bruteForce(a, b, tree.getResolution(), 2), walkOctree(a, b, true), "level segment");
  }
}

TEST_F(VoxelTraversalTest, AxisParallelSegments) {
  for (int axis = 0; axis < 3; ++axis) {
    for (double length : {-0.73, -0.05, 0.01, 0.33, 1.2}) {
      const Eigen::Vector3d a = randomPoint();
      Eigen::Vector3d b = a;
      b[axis] += length;
      expectSameWalk(bruteForce(a, b, tree.getResolution(), 3), walkOctree(a, b, false), "axis-parallel segment");
    }
  }
  const Eigen::Vector3d p(0.012, -0.3, 0.26);  // a segment inside one voxel: that voxel
  EXPECT_EQ(walkOctree(p, p + Eigen::Vector3d(0.01, 0.01, 0.0), false).size(), 1u);
}

// Segments that start or end on voxel boundaries (corners, edges, faces) or barely move along an
// axis: there crossings tie or rounding puts them on the wrong side of the end, and the walk must
// still stay in the key box of its ends (a window over that box is all the tracer has), move one
// voxel at a time and end on the end's voxel.
TEST(VoxelTraversalEnds, WalksOnBoundariesStayInTheirEndsBox) {
  octomap::OcTree tree(0.1);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> cell(-25, 25), pick(0, 5);
  // Per coordinate: on a boundary, a rounding's width off it, a denormal, or anywhere.
  const auto coordinate = [&](int c) {
    switch (pick(rng)) {
      case 0:
        return c * 0.1;
      case 1:
        return c * 0.1 + 1e-15;
      case 2:
        return c * 0.1 - 1e-15;
      case 3:
        return c == 0 ? 2.4e-43 : std::nextafter(c * 0.1, 0.0);
      case 4:
        return -6.35e-16;
      default:
        return (c + 0.37) * 0.1;
    }
  };
  const auto point = [&] {
    return Eigen::Vector3d(coordinate(cell(rng)), coordinate(cell(rng)), coordinate(cell(rng)));
  };
  int walks = 0;
  for (int n = 0; n < 20000; ++n) {
    const Eigen::Vector3d a = n % 3 == 0 ? Eigen::Vector3d::Zero() : point(), b = point();
    Eigen::Vector3d from = a, to = b;
    if (n % 2) std::swap(from, to);
    // The end of the tracer's input that stopped it: a return just above the sensor, off the axis by a rounding.
    if (n == 0) to = Eigen::Vector3d(-6.35003607e-16, 2.41023336e-43, 2.00029325);
    octomap::OcTreeKey kf, kt;
    ASSERT_TRUE(tree.coordToKeyChecked(from.x(), from.y(), from.z(), kf));
    ASSERT_TRUE(tree.coordToKeyChecked(to.x(), to.y(), to.z(), kt));
    int distance = 0;
    for (int d = 0; d < 3; ++d) distance += std::abs(int(kt[d]) - int(kf[d]));
    std::vector<octomap::OcTreeKey> visited;
    std::vector<double> exits;
    traverseVoxels(tree, from, to, kf, kt, PackedKeys{}, [&](std::uint64_t p, double t_exit) {
      visited.push_back(PackedKeys::keyOf(p));
      exits.push_back(t_exit);
    });
    // Each voxel but the last is left within the segment.
    for (std::size_t v = 0; v + 1 < exits.size(); ++v) EXPECT_LE(exits[v], 1.0 + 1e-9) << "segment " << n;
    ASSERT_EQ(visited.size(), std::size_t(distance) + 1) << "segment " << n;
    EXPECT_EQ(visited.front(), kf) << "segment " << n;
    EXPECT_EQ(visited.back(), kt) << "segment " << n;
    for (std::size_t v = 0; v < visited.size(); ++v) {
      for (int d = 0; d < 3; ++d) {
        EXPECT_GE(visited[v][d], std::min(kf[d], kt[d])) << "segment " << n << " voxel " << v << " axis " << d;
        EXPECT_LE(visited[v][d], std::max(kf[d], kt[d])) << "segment " << n << " voxel " << v << " axis " << d;
      }
      if (v == 0) continue;
      int moved = 0;
      for (int d = 0; d < 3; ++d) moved += std::abs(int(visited[v][d]) - int(visited[v - 1][d]));
      EXPECT_EQ(moved, 1) << "segment " << n << " voxel " << v;
    }
    walks += distance > 0;
  }
  EXPECT_GT(walks, 15000);
}

// The global pass walks its 2D grid in cells of travel (t is the distance travelled, in cells),
// set up from the ray's fractional cell coordinates, and stops where its visitor says so.
TEST(WalkPlaneTest, CellsOfTravelAndStopping) {
  std::mt19937 rng(5);
  // Cells on both sides of 0 (the pass's rays start and end outside its grid too).
  std::uniform_real_distribution<double> u(-40.0, 40.0), angle(-M_PI, M_PI), len(0.0, 20.0);
  for (int n = 0; n < 300; ++n) {
    const double fx = u(rng), fy = u(rng), a = angle(rng), length = len(rng);  // in cells
    const double dx = std::cos(a), dy = std::sin(a);
    int i = int(std::floor(fx)), j = int(std::floor(fy));
    const int ie = int(std::floor(fx + dx * length)), je = int(std::floor(fy + dy * length));
    const WalkAxis x{dx > 0 ? 1 : -1, (dx > 0 ? (i + 1 - fx) : (fx - i)) / std::abs(dx), 1.0 / std::abs(dx)};
    const WalkAxis y{dy > 0 ? 1 : -1, (dy > 0 ? (j + 1 - fy) : (fy - j)) / std::abs(dy), 1.0 / std::abs(dy)};
    std::vector<Crossed> walked;
    EXPECT_TRUE(walkPlane(i, j, x, y, std::abs(ie - i) + std::abs(je - j), [&](int ci, int cj, double t) {
      walked.push_back({{ci, cj, 0}, t / length});
    }));
    expectSameWalk(bruteForce({fx, fy, 0}, {fx + dx * length, fy + dy * length, 0}, 1.0, 2), walked, "grid ray");
    EXPECT_EQ(i, walked.back().cell[0]);  // the walk leaves (i, j) at its last cell
    EXPECT_EQ(j, walked.back().cell[1]);
    if (walked.size() < 3) continue;
    int si = int(std::floor(fx)), sj = int(std::floor(fy)), visits = 0;
    EXPECT_FALSE(walkPlane(si, sj, x, y, std::abs(ie - si) + std::abs(je - sj), [&](int, int, double) {
      return ++visits < 2;  // stop at the second cell
    }));
    EXPECT_EQ(visits, 2);
    EXPECT_EQ(si, walked[1].cell[0]);
    EXPECT_EQ(sj, walked[1].cell[1]);
  }
}

}  // namespace
