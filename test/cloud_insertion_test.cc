// Depth-camera clouds into the octree: the simulated camera, the fast path against a
// straightforward reference of the same model, and the cloud rules (floor, range, bad points).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <tuple>
#include <unordered_map>

#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/internal/scan_inserter.h"
#include "core/internal/scan_inserter_inspection.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "core/internal/map_evaluation.h"
#include "octo_slice_mapper/map_io.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

// A small camera (same optics, fewer pixels) keeps the reference fast.
sim::DepthCameraSpec smallCamera() {
  sim::DepthCameraSpec spec;
  spec.width = 160;
  spec.height = 120;
  return spec;
}

std::vector<Eigen::Vector3f> inMap(const std::vector<Eigen::Vector3f>& optical, const Eigen::Isometry3d& pose) {
  std::vector<Eigen::Vector3f> out;
  for (const Eigen::Vector3f& p : optical) {
    out.push_back(p.allFinite() ? Eigen::Vector3f((pose * p.cast<double>()).cast<float>()) : p);
  }
  return out;
}

struct Frame {
  Eigen::Isometry3d pose;
  std::vector<Eigen::Vector3f> points;  // map frame, NaN where no depth
};

Frame frameOf(const Eigen::Vector3d& at, double yaw, double pitch, const sim::DepthCameraSpec& spec, int seed = 1) {
  std::mt19937 rng(seed);
  Frame f;
  f.pose = sim::opticalPose(at, yaw, pitch);
  f.points = inMap(sim::depthFrame(sim::BoxScene::officeRoom(), f.pose, spec, &rng), f.pose);
  return f;
}

}  // namespace

TEST(DepthCamera, SeesTheWallAtItsDistanceAlongTheOpticalAxis) {
  sim::DepthCameraSpec spec = smallCamera();
  spec.noise = false;
  // 3 m from the east wall (x = 6), level, at mid-height: the centre pixel's depth is 3 m, on z.
  const Eigen::Isometry3d pose = sim::opticalPose(Eigen::Vector3d(3.0, 2.5, 1.5), 0.0, 0.0);
  std::mt19937 rng(1);
  const std::vector<Eigen::Vector3f> frame = sim::depthFrame(sim::BoxScene::officeRoom(), pose, spec, &rng);
  ASSERT_EQ(frame.size(), 160u * 120u);
  const Eigen::Vector3f centre = frame[60 * 160 + 80];
  EXPECT_NEAR(centre.z(), 3.0f, 1e-4f);
  EXPECT_NEAR((pose * centre.cast<double>()).x(), 6.0, 1e-3);
  // Right in the image is +x (REP 103), which looking east is -y in the world.
  const Eigen::Vector3d right = pose * frame[60 * 160 + 159].cast<double>();
  EXPECT_LT(right.y(), 2.5);
  // Looking along the 6 m diagonal of the room from a corner, the far corner is beyond 4.5 m: NaN.
  const Eigen::Isometry3d corner = sim::opticalPose(Eigen::Vector3d(0.1, 0.1, 1.2), std::atan2(5.0, 6.0), 0.0);
  const std::vector<Eigen::Vector3f> far = sim::depthFrame(sim::BoxScene::officeRoom(), corner, spec, &rng);
  EXPECT_FALSE(far[60 * 160 + 80].allFinite());
}

TEST(CloudInsertion, OneRayPerEndVoxelCountsEveryPointAndNeedsFewRays) {
  const Frame f = frameOf(Eigen::Vector3d(2.0, 1.8, 1.0), 0.0, 0.7, smallCamera());
  octomap::OcTree tree(0.05);
  ScanInserter inserter(&tree, InsertOptions());
  ReadingCounts counts;
  const std::vector<Beam> beams = ScanInserterInspection(inserter).cloudBeams(f.pose.translation(), f.points, &counts);
  std::size_t finite = 0;
  for (const Eigen::Vector3f& p : f.points) finite += p.allFinite();
  EXPECT_EQ(counts[ReadingKind::kHit], finite);
  EXPECT_EQ(counts[ReadingKind::kNaN], f.points.size() - finite);
  EXPECT_GT(finite, 10000u);
  EXPECT_LT(beams.size(), finite / 4) << "one ray per end voxel";
}

// The fast path (evidence window, layer cache, octree order) against the model's straightforward
// use: every beam's evidence for every voxel it reaches, summed per voxel over the frame, then
// OctoMap's updateNode; both trees leaf for leaf, over several frames (clamping included). Every
// ray walked whole: forwards (cloud_shared_free_run 0), and backwards from its end as the shared
// free space walks it, with a run that never stops it.
TEST(CloudInsertion, FastPathGivesTheReferenceTreeLeafForLeaf) {
  const sim::DepthCameraSpec spec = smallCamera();
  std::vector<Frame> frames;
  for (int k = 0; k < 3; ++k) {
    frames.push_back(frameOf(Eigen::Vector3d(2.0 + 0.05 * k, 1.8, 1.0), 0.02 * k, 0.7, spec, k + 1));
    frames.push_back(frameOf(Eigen::Vector3d(0.3 + 0.05 * k, 0.3, 0.3), 0.7, 0.05, spec, k + 10));
  }
  constexpr int kNeverStops = 1 << 30;
  for (const auto& [per_voxel, combining, shared_run] : {std::tuple{true, EvidenceCombining::kOccupiedWins, 0},
                                                         std::tuple{false, EvidenceCombining::kOccupiedWins, 0},
                                                         std::tuple{true, EvidenceCombining::kOccupiedWins, kNeverStops},
                                                         std::tuple{true, EvidenceCombining::kSum, 16}}) {
    MapperOptions options;
    options.insert.cloud_one_ray_per_voxel = per_voxel;
    options.insert.cloud_combining = combining;
    options.insert.cloud_shared_free_run = shared_run;  // summed evidence: never shared
    options.floor.find = false;  // the reference below measures heights from z = 0 (ScanInserterInspection)
    Mapper fast(options);
    octomap::OcTree reference(options.resolution);
    reference.setClampingThresMin(options.clamp_min);
    reference.setClampingThresMax(options.clamp_max);
    octomap::OcTree scratch(options.resolution);
    ScanInserter tracer(&scratch, options.insert);
    for (const Frame& f : frames) {
      ASSERT_TRUE(fast.insertPoints(f.pose.translation(), f.points).ok());
      const std::vector<Beam> beams = ScanInserterInspection(tracer).cloudBeams(f.pose.translation(), f.points, nullptr);
      // Per voxel: the sum, or where occupied wins the strongest occupied evidence, else the
      // strongest free.
      struct Combined {
        float sum = 0.0f, most = 0.0f, least = 0.0f;
      };
      std::unordered_map<octomap::OcTreeKey, Combined, octomap::OcTreeKey::KeyHash> evidence;
      ScanInserterInspection(tracer).traceEvidence(f.pose.translation(), beams, tracer.model().halfAngleFor(0.0),
                           [&](const octomap::OcTreeKey& key, float value) {
                             Combined& c = evidence[key];
                             c.sum += value;
                             c.most = std::max(c.most, value);
                             c.least = std::min(c.least, value);
                           });
      for (const auto& kv : evidence) {
        const Combined& c = kv.second;
        const float value = combining == EvidenceCombining::kSum ? c.sum : c.most > 0.0f ? c.most : c.least;
        if (value != 0.0f) reference.updateNode(kv.first, value);
      }
    }
    const octomap::OcTree& tree = fast.tree();
    ASSERT_GT(reference.getNumLeafNodes(), 1000u);
    std::size_t compared = 0;
    for (auto it = reference.begin_leafs(); it != reference.end_leafs(); ++it) {
      const octomap::OcTreeNode* node = tree.search(it.getKey());
      ASSERT_NE(node, nullptr) << "missing leaf at " << it.getCoordinate();
      ASSERT_NEAR(node->getLogOdds(), it->getLogOdds(), 1e-3)
          << "at " << it.getCoordinate() << " per_voxel " << per_voxel << " combining " << int(combining)
          << " shared_run " << shared_run;
      ++compared;
    }
    EXPECT_EQ(compared, reference.getNumLeafNodes());
    if (shared_run == 0 || combining == EvidenceCombining::kSum) {
      EXPECT_EQ(tree.getNumLeafNodes(), reference.getNumLeafNodes()) << "the fast path has voxels the reference has not";
    } else {
      // Walked backwards, a ray that passes within rounding of a voxel edge may step the other
      // way round it: such a voxel is crossed on the way back only, and is free.
      std::size_t extra = 0;
      for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
        if (reference.search(it.getKey())) continue;
        ++extra;
        EXPECT_LT(it->getLogOdds(), 0.0f) << "an occupied voxel only the backward walk has, at " << it.getCoordinate();
      }
      EXPECT_LT(extra, reference.getNumLeafNodes() / 1000) << "voxels only the backward walk crosses";
      std::printf("backward walk: %zu of %zu voxels not crossed forwards\n", extra, tree.getNumLeafNodes());
    }
  }
}

// Shared free space (cloud_shared_free_run): a ray stops in free space that earlier rays of the
// frame cleared. Against every ray walked whole, on full 640 x 480 frames of the room and the desk:
// every occupied update is the same (each ray's end is always walked), a free update is never
// stronger than the whole walk's, and few voxels miss this frame's update.
TEST(CloudInsertion, SharedFreeSpaceLosesOnlyAFewFreeUpdatesOfAFrame) {
  const sim::DepthCameraSpec spec;  // the full frame: the rays as dense as a camera's
  for (const Frame& f : {frameOf(Eigen::Vector3d(0.3, 0.3, 0.3), 0.7, 0.05, spec, 3),
                         frameOf(Eigen::Vector3d(2.0, 1.8, 1.0), 0.0, 0.7, spec, 4)}) {
    InsertOptions whole_options, shared_options;
    whole_options.cloud_shared_free_run = 0;
    shared_options.cloud_shared_free_run = 16;
    octomap::OcTree whole_tree(0.05), shared_tree(0.05);
    ScanInserter whole(&whole_tree, whole_options), shared(&shared_tree, shared_options);
    const double half_angle = whole.model().halfAngleFor(0.0);
    const PreparedCloud a = whole.prepareCloud(f.pose.translation(), f.points, half_angle);
    const PreparedCloud b = shared.prepareCloud(f.pose.translation(), f.points, half_angle);
    ASSERT_TRUE(a.result.ok());
    ASSERT_TRUE(b.result.ok());
    std::unordered_map<octomap::OcTreeKey, float, octomap::OcTreeKey::KeyHash> reference;
    std::size_t occupied = 0;
    for (const KeyUpdate& u : a.updates) {
      reference[u.key] = u.log_odds;
      occupied += u.log_odds > 0.0f;
    }
    ASSERT_GT(reference.size(), 5000u);
    ASSERT_GT(occupied, 200u);
    std::size_t occupied_shared = 0, only_backwards = 0;
    for (const KeyUpdate& u : b.updates) {
      const auto it = reference.find(u.key);
      if (it == reference.end()) {  // crossed only walking backwards (see FastPathGivesTheReferenceTreeLeafForLeaf)
        ++only_backwards;
        ASSERT_LT(u.log_odds, 0.0f);
        continue;
      }
      if (it->second > 0.0f) {
        ASSERT_EQ(u.log_odds, it->second) << "an occupied update changed";
        ++occupied_shared;
      } else {
        ASSERT_LT(u.log_odds, 0.0f);
        ASSERT_GE(u.log_odds, it->second) << "a free update stronger than the whole rays'";
      }
    }
    EXPECT_EQ(occupied_shared, occupied) << "every occupied update is kept";
    EXPECT_LT(only_backwards, a.updates.size() / 1000);
    const double missed = 1.0 - double(b.updates.size() - only_backwards) / double(a.updates.size());
    EXPECT_LT(missed, 0.02) << "of " << a.updates.size() << " voxels";
    EXPECT_GE(missed, 0.0);
    // The readings are counted alike.
    EXPECT_EQ(b.result.readings[ReadingKind::kHit], a.result.readings[ReadingKind::kHit]);
    RecordProperty("missed_share", std::to_string(missed));
    std::printf("shared free space: %zu of %zu voxels updated (%.2f %% missed)\n", b.updates.size(), a.updates.size(),
                100.0 * missed);
  }
}

// Walking a ray backwards, the model is not asked for a voxel that already holds the free valley
// where the ray's evidence cannot be above zero: there it cannot change the voxel. The updates are
// the same, value for value, with the model asked everywhere: full frames of the room (returns
// and, cut at 2 m, rays that clear only) and of the desk.
TEST(CloudInsertion, SkippingVoxelsTheFreeValleyHoldsChangesNoUpdate) {
  const sim::DepthCameraSpec spec;
  struct Case {
    Frame frame;
    double max_range;
  };
  for (const Case& c : {Case{frameOf(Eigen::Vector3d(0.3, 0.3, 0.3), 0.7, 0.05, spec, 3), 0.0},
                        Case{frameOf(Eigen::Vector3d(0.3, 0.3, 0.3), 0.7, 0.05, spec, 3), 2.0},
                        Case{frameOf(Eigen::Vector3d(2.0, 1.8, 1.0), 0.0, 0.7, spec, 4), 0.0}}) {
    InsertOptions options;
    options.cloud_max_range = c.max_range;
    octomap::OcTree asked_tree(0.05), skipping_tree(0.05);
    ScanInserter asked(&asked_tree, options), skipping(&skipping_tree, options);
    ScanInserterInspection(asked).skipSettledVoxels(false);
    const double half_angle = asked.model().halfAngleFor(0.0);
    const PreparedCloud a = asked.prepareCloud(c.frame.pose.translation(), c.frame.points, half_angle);
    const PreparedCloud b = skipping.prepareCloud(c.frame.pose.translation(), c.frame.points, half_angle);
    ASSERT_TRUE(a.result.ok());
    ASSERT_GT(a.updates.size(), 5000u);
    ASSERT_EQ(a.updates.size(), b.updates.size());
    std::size_t occupied = 0;
    for (std::size_t i = 0; i < a.updates.size(); ++i) {
      ASSERT_EQ(a.updates[i].key, b.updates[i].key) << i;
      ASSERT_EQ(a.updates[i].log_odds, b.updates[i].log_odds) << i;
      occupied += a.updates[i].log_odds > 0.0f;
    }
    // Cut at 2 m, the room's walls are beyond: its rays clear only.
    if (c.max_range == 0.0) {
      EXPECT_GT(occupied, 100u) << "returns are marked";
    }
  }
}

// A frame's changes go to the slice with each voxel's value before and after, so that most
// columns follow from their own cell: after depth frames (into a fresh map and into one that scans
// and earlier frames filled, the laser's layer cached), the slice is cell for cell the one a
// rebuild from the octree gives.
TEST(CloudInsertion, TheSliceFollowsDepthFramesAsARebuildReadsThem) {
  MapperOptions options;
  options.slice.min_z = 0.05;  // the navigation band: the frames reach all of its layers
  options.slice.max_z = 0.80;
  Mapper mapper(options);
  const sim::DepthCameraSpec spec = smallCamera();
  const auto expect_matches_rebuild = [&](const char* when) {
    SliceGrid rebuilt(mapper.tree(), mapper.options().slice);
    rebuilt.rebuild();
    const SliceGrid& live = mapper.slice();
    ASSERT_EQ(live.knownCells(), rebuilt.knownCells()) << when;
    std::size_t occupied = 0;
    for (int j = 0; j < live.height(); ++j) {
      for (int i = 0; i < live.width(); ++i) {
        const double x = live.originX() + (i + 0.5) * live.resolution(), y = live.originY() + (j + 0.5) * live.resolution();
        ASSERT_EQ(live.at(i, j), rebuilt.valueAt(x, y)) << when << ": " << x << ", " << y;
        occupied += live.at(i, j) > 65;
      }
    }
    EXPECT_GT(occupied, 20u) << when;
  };
  for (int k = 0; k < 4; ++k) {
    const Frame f = frameOf(Eigen::Vector3d(0.3 + 0.4 * k, 0.3 + 0.2 * k, 0.3), 0.7 - 0.3 * k, 0.1, spec, k + 1);
    ASSERT_TRUE(mapper.insertPoints(f.pose.translation(), f.points).ok());
  }
  expect_matches_rebuild("frames into a fresh map");
  // A level scan caches the laser's layer; frames then change its voxels through the cache.
  for (int k = 0; k < 3; ++k) {
    const Scan scan = test_support::makeScan(test_support::laserPoseOnRobot(0.5 + 0.3 * k, 0.6, 0.5 * k), -1.5f,
                                             0.01f, std::vector<float>(301, 2.5f));
    ASSERT_TRUE(mapper.insert(scan).ok());
  }
  for (int k = 0; k < 4; ++k) {
    const Frame f = frameOf(Eigen::Vector3d(1.8 - 0.3 * k, 1.5, 0.3), 3.0 + 0.4 * k, 0.05, spec, k + 11);
    ASSERT_TRUE(mapper.insertPoints(f.pose.translation(), f.points).ok());
  }
  expect_matches_rebuild("frames after scans");
}

TEST(CloudInsertion, TheFloorClearsButDoesNotMarkAndTheTableTopMarks) {
  // Looking down at the table from above its centre: the top at 0.72 m is occupied, the floor
  // beside it (z = 0, below cloud_mark_min_z) is not, and the air above the table is free.
  Mapper mapper{MapperOptions()};
  for (int k = 0; k < 3; ++k) {
    const Frame f = frameOf(Eigen::Vector3d(2.0, 1.9, 1.2), 0.0, 0.6 + 0.05 * k, smallCamera(), k + 1);
    ASSERT_TRUE(mapper.insertPoints(f.pose.translation(), f.points).ok());
  }
  const octomap::OcTree& tree = mapper.tree();
  const auto occupied = [&](double x, double y, double z) {
    const octomap::OcTreeNode* n = tree.search(x, y, z);
    return n && tree.isNodeOccupied(n);
  };
  const auto known_free = [&](double x, double y, double z) {
    const octomap::OcTreeNode* n = tree.search(x, y, z);
    return n && !tree.isNodeOccupied(n);
  };
  int top = 0, floor_marked = 0, floor_seen = 0;
  for (double x = 2.6; x < 3.6; x += 0.05) {
    top += occupied(x, 1.9, 0.71);
    floor_marked += occupied(x, 1.2, 0.01);
    floor_seen += tree.search(x, 1.2, 0.01) != nullptr;
  }
  EXPECT_GT(top, 12) << "of 20 cells along the table top";
  EXPECT_GT(floor_seen, 0) << "the floor beside the table was not seen at all";
  EXPECT_EQ(floor_marked, 0);
  EXPECT_TRUE(known_free(2.6, 1.9, 1.0)) << "the air between the camera and the table";
}

// A first frame has no seed: its floor is looked for in the whole view, where the floor is a
// minority of the returns. The plane fit's random draws follow the order of the frame's end
// voxels, which any change to the grouping may change: the floor must be found in every order.
TEST(CloudInsertion, AFirstFramesFloorIsFoundWhateverTheOrderOfItsPoints) {
  std::mt19937 rng(7);
  for (int k = 0; k < 8; ++k) {
    const double a = 2.0 * M_PI * k / 8;
    const Frame f = frameOf(Eigen::Vector3d(3.0 + 1.9 * std::cos(a), 3.2 + 0.5 * std::sin(a), 1.0), a + 0.9, 0.45,
                            smallCamera(), k + 1);
    for (const Eigen::Isometry3d& world :
         {Eigen::Isometry3d::Identity(), Eigen::Isometry3d(Eigen::AngleAxisd(1.5 * M_PI / 180.0, Eigen::Vector3d::UnitX()))}) {
      std::vector<Eigen::Vector3f> points;
      for (const Eigen::Vector3f& p : f.points) {
        if (p.allFinite()) points.push_back((world * p.cast<double>()).cast<float>());
      }
      for (int order = 0; order < 40; ++order) {
        std::shuffle(points.begin(), points.end(), rng);
        Mapper mapper;
        ASSERT_TRUE(mapper.insertPoints(world * f.pose.translation(), points).ok());
        EXPECT_EQ(mapper.floor().status().frames_found, 1u) << "frame " << k << ", order " << order;
      }
    }
  }
}

TEST(CloudInsertion, TheNavigationSliceIsTheSameWhereverTheFixedFrameHasTheFloor) {
  // The room seen from a loop of poses, mapped as recorded, with the world 1.5 m down (a
  // hand-held camera's frame) and with it turned 1.5 degrees (a mount or odometry that is off):
  // the navigation band is measured from the floor found, so the three slices agree.
  std::vector<Frame> frames;
  for (int k = 0; k < 8; ++k) {
    const double a = 2.0 * M_PI * k / 8;
    frames.push_back(frameOf(Eigen::Vector3d(3.0 + 1.9 * std::cos(a), 3.2 + 0.5 * std::sin(a), 1.0), a + 0.9, 0.45,
                             smallCamera(), k + 1));
  }
  const auto sliceOf = [&](const Eigen::Isometry3d& world) {
    MapperOptions options;
    options.slice.min_z = 0.05;
    options.slice.max_z = 0.80;
    Mapper mapper(options);
    for (const Frame& f : frames) {
      std::vector<Eigen::Vector3f> points;
      for (const Eigen::Vector3f& p : f.points) points.push_back(p.allFinite() ? Eigen::Vector3f((world * p.cast<double>()).cast<float>()) : p);
      EXPECT_TRUE(mapper.insertPoints(world * f.pose.translation(), points).ok());
    }
    EXPECT_EQ(mapper.floor().status().frames_found, frames.size());
    return gridImageOf(mapper.slice());
  };
  const GridImage recorded = sliceOf(Eigen::Isometry3d::Identity());
  const OccupancyScore self = scoreOccupancy(recorded, recorded, 1);
  ASSERT_GT(self.map_occupied, 300u);
  for (const Eigen::Isometry3d& world :
       {Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -1.5)),
        Eigen::Isometry3d(Eigen::AngleAxisd(1.5 * M_PI / 180.0, Eigen::Vector3d::UnitX()))}) {
    const GridImage moved = sliceOf(world);
    const OccupancyScore score = scoreOccupancy(moved, recorded, 1);
    EXPECT_GT(score.precision, 0.97);
    EXPECT_GT(score.recall, 0.97);
  }
  // Without floor finding, the frame's z = 0 is the floor: 1.5 m down, nothing is in the band.
  MapperOptions assumed;
  assumed.floor.find = false;
  assumed.slice.min_z = 0.05;
  assumed.slice.max_z = 0.80;
  Mapper mapper(assumed);
  const Eigen::Isometry3d down(Eigen::Translation3d(0.0, 0.0, -1.5));
  for (const Frame& f : frames) {
    std::vector<Eigen::Vector3f> points;
    for (const Eigen::Vector3f& p : f.points) points.push_back(p.allFinite() ? Eigen::Vector3f((down * p.cast<double>()).cast<float>()) : p);
    mapper.insertPoints(down * f.pose.translation(), points);
  }
  EXPECT_EQ(scoreOccupancy(gridImageOf(mapper.slice()), recorded, 1).map_occupied, 0u);
}

TEST(CloudInsertion, FarFloorNoiseDoesNotMarkButALowStepNearbyDoes) {
  // A floor seen out to 4.5 m whose returns scatter in height by a Kinect's noise at their
  // range (the model's sigma, 2-3 cm beyond 3.5 m) and, 1.5 m away, the top of a 6 cm step: the
  // far floor clears only, the step marks.
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const Eigen::Vector3d origin(0.0, 0.0, 1.0);
  std::vector<Eigen::Vector3f> points;
  for (double x = 0.6; x < 4.5; x += 0.02) {
    for (double y = -1.0; y < 1.0; y += 0.05) {
      const bool step = x >= 1.5 && x < 1.7 && std::abs(y) < 0.3;
      const double r = (Eigen::Vector3d(x, y, 0.0) - origin).norm();
      const double sigma = 0.0012 + 0.0019 * (r - 0.4) * (r - 0.4);
      points.emplace_back(float(x), float(y), float((step ? 0.06 : 0.0) + sigma * gauss(rng)));
    }
  }
  Mapper mapper{MapperOptions()};
  ASSERT_TRUE(mapper.insertPoints(origin, points).ok());
  EXPECT_EQ(mapper.floor().status().source, FloorSource::kFound);
  const octomap::OcTree& tree = mapper.tree();
  int far_marked = 0, step_marked = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    if (it.getX() > 3.5) ++far_marked;
    if (it.getX() > 1.45 && it.getX() < 1.75) ++step_marked;
  }
  EXPECT_EQ(far_marked, 0);
  EXPECT_GT(step_marked, 10);
}

TEST(CloudInsertion, CloudMaxRangeClearsUpToItAndMarksNothingBeyond) {
  MapperOptions options;
  options.insert.cloud_max_range = 2.0;
  Mapper mapper(options);
  // One point on a wall 3 m ahead, at a marking height.
  const Eigen::Vector3d origin(0.0, 0.0, 0.5);
  ASSERT_TRUE(mapper.insertPoints(origin, {Eigen::Vector3f(3.0f, 0.0f, 0.5f)}).ok());
  const octomap::OcTree& tree = mapper.tree();
  const octomap::OcTreeNode* at_wall = tree.search(3.0, 0.0, 0.5);
  EXPECT_TRUE(at_wall == nullptr || !tree.isNodeOccupied(at_wall)) << "marked beyond cloud_max_range";
  const octomap::OcTreeNode* near = tree.search(1.5, 0.0, 0.5);
  ASSERT_NE(near, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(near));
  EXPECT_EQ(tree.search(2.6, 0.0, 0.5), nullptr) << "cleared past cloud_max_range";
}

TEST(CloudInsertion, NonFinitePointsAreCountedPerReasonAndLoseNothing) {
  Mapper mapper{MapperOptions()};
  const Frame f = frameOf(Eigen::Vector3d(2.0, 1.8, 1.0), 0.0, 0.7, smallCamera());
  ASSERT_TRUE(mapper.insertPoints(f.pose.translation(), f.points).ok());
  const std::size_t leaves = mapper.tree().getNumLeafNodes();
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  std::vector<Eigen::Vector3f> bad(1000000, Eigen::Vector3f(nan, nan, nan));
  bad[5] = Eigen::Vector3f(inf, 0.0f, 0.0f);
  bad[6] = Eigen::Vector3f(1e30f, 1e30f, 1e30f);  // huge: outside the octree
  const InsertResult result = mapper.insertPoints(f.pose.translation(), bad);
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.readings[ReadingKind::kNaN], 999998u);
  EXPECT_EQ(result.readings[ReadingKind::kInfinite], 1u);
  EXPECT_EQ(result.beams_outside_octree, 1u) << "the 1e30 m point: dropped, and counted";
  EXPECT_EQ(mapper.stats().beams_outside_octree, 1u);
  EXPECT_EQ(mapper.tree().getNumLeafNodes(), leaves) << "bad points changed the map";
}

// Why a cloud's rays combine with occupied winning: a TurtleBot's camera (0.30 m up) sees the
// table top (0.69-0.72 m) from below, at a grazing angle; summed, the free evidence of the rays
// ending farther along the underside erases the voxels where the nearer ones end.
TEST(CloudInsertion, OccupiedWinsKeepsATableTopSeenFromBelowThatSummingErases) {
  sim::DepthCameraSpec spec;
  spec.width = 320, spec.height = 240;
  int occupied[2] = {0, 0}, cells = 0;
  for (int k = 0; k < 2; ++k) {
    MapperOptions options;
    options.insert.cloud_combining = k == 0 ? EvidenceCombining::kOccupiedWins : EvidenceCombining::kSum;
    options.slice.min_z = 0.05, options.slice.max_z = 0.80;
    Mapper mapper(options);
    for (int f = 0; f < 3; ++f) {
      const Frame frame = frameOf(Eigen::Vector3d(0.9, 1.9, 0.30), 0.05 * f, 0.1, spec, f + 1);
      ASSERT_TRUE(mapper.insertPoints(frame.pose.translation(), frame.points).ok());
    }
    cells = 0;
    for (double x = 2.55; x < 3.5; x += 0.1) {
      for (double y = 1.7; y < 2.15; y += 0.1) {
        ++cells;
        occupied[k] += mapper.slice().valueAt(x, y) >= 65;
      }
    }
  }
  EXPECT_GT(occupied[0], cells * 8 / 10) << "occupied wins: " << occupied[0] << " of " << cells;
  EXPECT_LT(occupied[1], cells * 3 / 10) << "summed: " << occupied[1] << " of " << cells;
}
