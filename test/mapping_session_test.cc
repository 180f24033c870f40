// The session the node and octo_slice_map share: saving with and without the global pass, the
// octree lent to a save while scans go on, reset and load waiting for a save, versions.
#include "octo_slice_mapper/mapping_session.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <atomic>
#include <cstdlib>
#include <thread>

#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

class MappingSessionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const sim::SimulatedSession office(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
    scans_ = new std::vector<Scan>(office.allScans());
  }
  static void TearDownTestSuite() { delete scans_; }
  void SetUp() override {
    char tmpl[] = "/tmp/osm_session_XXXXXX";
    dir_ = ::mkdtemp(tmpl);
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }

  static void insertAll(MappingSession* session, std::size_t from, std::size_t to) {
    for (std::size_t k = from; k < to; ++k) ASSERT_TRUE(session->insert((*scans_)[k]).ok());
  }
  static std::string bytesOf(const std::string& path) {
    std::string bytes, error;
    EXPECT_TRUE(readFile(path, &bytes, &error)) << error;
    return bytes;
  }

  static std::vector<Scan>* scans_;
  std::string dir_;
};
std::vector<Scan>* MappingSessionTest::scans_ = nullptr;

// A save without the pass writes what the Mapper's own save writes, and the incremental slice
// beside it; with the pass, PREFIX.* is the pass's map, and the result goes into the live map only
// when asked to.
TEST_F(MappingSessionTest, SaveWritesTheBestMapAndTheIncrementalSliceBesideIt) {
  SessionOptions options;
  options.write_optimized_into_map = false;
  MappingSession session(MapperOptions(), options);
  Mapper plain;
  insertAll(&session, 0, 60);
  for (std::size_t k = 0; k < 60; ++k) plain.insert((*scans_)[k]);

  SaveOutcome saved = session.save(dir_ + "/s", /*with_global_pass=*/false);
  ASSERT_TRUE(saved.ok) << saved.error;
  EXPECT_EQ(saved.files.size(), 9u);
  EXPECT_FALSE(saved.optimized);
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(plain.save(dir_ + "/p", &written, &error)) << error;
  EXPECT_EQ(bytesOf(dir_ + "/s.bt"), bytesOf(dir_ + "/p.bt"));
  EXPECT_EQ(bytesOf(dir_ + "/s.ot"), bytesOf(dir_ + "/p.ot"));
  GridImage best, incremental;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/s.yaml", &best, &error)) << error;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/s_incremental.yaml", &incremental, &error)) << error;
  EXPECT_EQ(best.cells, incremental.cells) << "without the pass, the best map is the incremental one";

  const std::uint64_t changes = session.changes();
  saved = session.save(dir_ + "/o", /*with_global_pass=*/true);
  ASSERT_TRUE(saved.ok) << saved.error;
  ASSERT_TRUE(saved.optimized);
  EXPECT_TRUE(saved.optimized->report.converged);
  EXPECT_EQ(saved.files.size(), 9u);
  ASSERT_TRUE(loadPgmYaml(dir_ + "/o.yaml", &best, &error)) << error;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/o_incremental.yaml", &incremental, &error)) << error;
  EXPECT_NE(best.cells, incremental.cells) << "with the pass, PREFIX.* is the pass's map";
  GridImage incremental_before;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/s_incremental.yaml", &incremental_before, &error)) << error;
  EXPECT_EQ(incremental.cells, incremental_before.cells) << "the same incremental slice as the save before";
  EXPECT_EQ(session.changes(), changes) << "write_optimized_into_map is off: the map is as it was";
}

// While a save (with the pass) holds the octree, scans keep going in; afterwards the map has them
// and the save is of the map as it was when it started.
TEST_F(MappingSessionTest, ScansGoOnWhileASaveHoldsTheOctree) {
  MappingSession session{MapperOptions(), SessionOptions()};
  insertAll(&session, 0, 40);
  std::atomic<bool> done{false};
  SaveOutcome saved;
  std::thread saver([&] {
    saved = session.save(dir_ + "/m", /*with_global_pass=*/true);
    done = true;
  });
  // This thread is the only one inserting: what the slice knows once the octree is lent is what
  // the save writes.
  while (!session.withMapper([](const Mapper& m) { return m.lent(); }) && !done) std::this_thread::yield();
  const std::size_t known_at_save = session.withMapper([](const Mapper& m) { return m.slice().knownCells(); });
  std::size_t inserted_during = 0;
  for (std::size_t k = 40; k < scans_->size(); ++k) {
    ASSERT_TRUE(session.insert((*scans_)[k]).ok());
    inserted_during += !done;
  }
  saver.join();
  ASSERT_TRUE(saved.ok) << saved.error;
  EXPECT_GT(inserted_during, 0u) << "no scan went in while the save ran: the test proved nothing";
  std::string error;
  // The incremental slice saved is the one of the scans inserted before the save began.
  Mapper before;
  for (std::size_t k = 0; k < 40; ++k) before.insert((*scans_)[k]);
  EXPECT_EQ(before.slice().knownCells(), known_at_save);
  GridImage saved_incremental;
  ASSERT_TRUE(loadPgmYaml(dir_ + "/m_incremental.yaml", &saved_incremental, &error)) << error;
  EXPECT_EQ(saved_incremental.cells, trinaryOf(gridImageOf(before.slice())).cells)
      << "the save is of the map when it started";
  EXPECT_GT(session.withMapper([](const Mapper& m) { return m.slice().knownCells(); }), known_at_save);
  EXPECT_FALSE(session.withMapper([](const Mapper& m) { return m.lent(); })) << "the loan ended";
}

// reset() and load() during a save wait for it (the Mapper refuses both while its octree is lent).
TEST_F(MappingSessionTest, ResetAndLoadWaitForARunningSave) {
  MappingSession session{MapperOptions(), SessionOptions()};
  insertAll(&session, 0, scans_->size());
  SaveOutcome first = session.save(dir_ + "/first", false);
  ASSERT_TRUE(first.ok) << first.error;
  SaveOutcome saved;
  std::atomic<bool> done{false};
  std::thread saver([&] {
    saved = session.save(dir_ + "/m", /*with_global_pass=*/true);
    done = true;
  });
  while (!session.withMapper([](const Mapper& m) { return m.lent(); }) && !done) std::this_thread::yield();
  EXPECT_NO_THROW(session.reset());
  saver.join();
  ASSERT_TRUE(saved.ok) << saved.error;
  EXPECT_EQ(session.withMapper([](const Mapper& m) { return m.slice().knownCells(); }), 0u) << "reset, after the save";

  std::thread again([&] { saved = session.save(dir_ + "/empty", false); });
  std::string error;
  EXPECT_TRUE(session.load(dir_ + "/first.ot", &error)) << error;
  again.join();
  EXPECT_GT(session.withMapper([](const Mapper& m) { return m.slice().knownCells(); }), 0u);
}

// version() tells a save on shutdown whether it would repeat the last; what a save's own pass
// writes back does not count, every other change does.
TEST_F(MappingSessionTest, VersionsTellWhetherASaveWouldRepeatTheLast) {
  MappingSession session{MapperOptions(), SessionOptions()};  // writes the pass's result back
  insertAll(&session, 0, 30);
  ASSERT_TRUE(session.save(dir_ + "/m", /*with_global_pass=*/true).ok);
  EXPECT_TRUE(session.savedAlready(dir_ + "/m"));
  EXPECT_FALSE(session.savedAlready(dir_ + "/other"));
  insertAll(&session, 30, 31);
  EXPECT_FALSE(session.savedAlready(dir_ + "/m")) << "a scan changed the map";
  ASSERT_TRUE(session.save(dir_ + "/m", false).ok);
  const std::uint64_t version = session.version();
  ASSERT_TRUE(session.optimize(/*warm_start=*/true));
  EXPECT_NE(session.version(), version) << "~optimize writes into the map: a change";
  session.reset();
  EXPECT_FALSE(session.savedAlready(dir_ + "/m"));
}

// The background pass gets an input only when the map changed, stamped with the newest scan's
// stamp; optimize() without kept scans does nothing.
TEST_F(MappingSessionTest, OnlinePassInputOnlyWhenTheMapChanged) {
  MappingSession session{MapperOptions(), SessionOptions()};
  EXPECT_FALSE(session.onlinePassInput()) << "nothing kept yet";
  EXPECT_FALSE(session.optimize(true));
  insertAll(&session, 0, 10);
  std::optional<OnlineOptimizerInput> input = session.onlinePassInput();
  ASSERT_TRUE(input);
  EXPECT_EQ(input->scans.size(), 10u);
  EXPECT_DOUBLE_EQ(input->newest_stamp, (*scans_)[9].stamp);
  EXPECT_FALSE(session.onlinePassInput()) << "unchanged since";
  insertAll(&session, 10, 11);
  input = session.onlinePassInput();
  ASSERT_TRUE(input);
  EXPECT_EQ(input->scans.size(), 11u);
}

bool sameScans(const std::vector<StoredScan>& a, const std::vector<StoredScan>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    // Byte for byte: the simulated scans hold NaN readings, which never compare equal.
    if (a[k].origin != b[k].origin || a[k].ranges.size() != b[k].ranges.size() ||
        std::memcmp(a[k].ranges.data(), b[k].ranges.data(), a[k].ranges.size() * sizeof(float)) != 0) {
      return false;
    }
  }
  return true;
}

// The pass's copy of the kept scans is kept up to date by appending under the lock: it must be
// the store's scans after appends, after a box clear dropped some, after a reset, after thinning.
TEST_F(MappingSessionTest, OnlinePassInputHoldsTheStoresScansWhateverChangedThem) {
  MapperOptions options;
  options.scan_store.max_scans = 30;  // thinning at the 31st
  MappingSession session{options, SessionOptions()};
  const auto kept = [&] { return session.withMapper([](const Mapper& m) { return m.scanStore().scans(); }); };
  const auto check = [&](const char* after) {
    std::optional<OnlineOptimizerInput> input = session.onlinePassInput();
    ASSERT_TRUE(input) << after;
    EXPECT_TRUE(sameScans(input->scans, kept())) << after << ": " << input->scans.size() << " vs " << kept().size();
  };
  insertAll(&session, 0, 10);
  check("the first scans");
  insertAll(&session, 10, 20);
  check("appending");
  Mapper::Cleared cleared;
  std::string error;
  const Eigen::Vector3d origin = kept()[3].origin.cast<double>();
  ASSERT_TRUE(session.clearBox(origin - Eigen::Vector3d::Constant(0.3), origin + Eigen::Vector3d::Constant(0.3),
                               &cleared, &error)) << error;
  ASSERT_LT(kept().size(), 20u) << "the box should drop the scans whose beams cross it";
  check("a box clear");
  insertAll(&session, 20, 40);
  check("thinning when full");
  session.reset();
  insertAll(&session, 0, 5);
  check("a reset");
}

}  // namespace

namespace {

// ~clear_box: the voxels inside the box are unknown again, the slice follows, those outside stay,
// and kept scans whose beams crossed the box are dropped.
TEST_F(MappingSessionTest, ClearBoxMakesTheBoxUnknownAndDropsTheScansThatSawIt) {
  MappingSession session{MapperOptions(), SessionOptions()};
  insertAll(&session, 0, scans_->size());
  const Eigen::Vector3d lo(-1.0, -1.0, -1.0), hi(1.0, 1.0, 1.0);
  auto known = [&](double x, double y) {
    return session.withMapper([&](const Mapper& m) { return m.slice().valueAt(x, y) != kUnknownCell; });
  };
  // A known cell inside and one outside the box.
  double in_x = 0.0, in_y = 0.0, out_x = 0.0, out_y = 0.0;
  bool found_in = false, found_out = false;
  for (double x = -4.0; x <= 4.0 && !(found_in && found_out); x += 0.05) {
    for (double y = -4.0; y <= 4.0; y += 0.05) {
      const bool inside = std::abs(x) < 0.9 && std::abs(y) < 0.9, outside = std::abs(x) > 1.2 || std::abs(y) > 1.2;
      if (!found_in && inside && known(x, y)) in_x = x, in_y = y, found_in = true;
      if (!found_out && outside && known(x, y)) out_x = x, out_y = y, found_out = true;
    }
  }
  ASSERT_TRUE(found_in && found_out) << "the session maps around the origin";
  const std::size_t kept = session.withMapper([](const Mapper& m) { return m.scanStore().scans().size(); });
  const std::uint64_t version = session.version();
  Mapper::Cleared cleared;
  std::string error;
  ASSERT_TRUE(session.clearBox(lo, hi, &cleared, &error)) << error;
  EXPECT_GT(cleared.voxels, 0u);
  EXPECT_GT(cleared.scans, 0u);
  EXPECT_LT(cleared.scans, kept) << "scans that never saw the box are kept";
  EXPECT_FALSE(known(in_x, in_y)) << "inside the box: unknown again";
  EXPECT_TRUE(known(out_x, out_y)) << "outside the box: kept";
  EXPECT_NE(session.version(), version);
  session.withMapper([&](Mapper& m) {
    const octomap::OcTree& tree = m.tree();
    for (auto it = tree.begin_leafs_bbx(octomap::point3d(-0.95f, -0.95f, -0.95f), octomap::point3d(0.95f, 0.95f, 0.95f));
         it != tree.end_leafs_bbx(); ++it) {
      ADD_FAILURE() << "a voxel is left in the box at " << it.getCoordinate();
      break;
    }
    // The slice equals one rebuilt from the tree.
    SliceGrid rebuilt(tree, m.options().slice);
    rebuilt.rebuild();
    EXPECT_EQ(rebuilt.knownCells(), m.slice().knownCells());
  });
  // The kept scans left do not cross the box: the global pass leaves it unknown.
  const std::optional<OptimizedMap> optimized = session.optimize(/*warm_start=*/false);
  ASSERT_TRUE(optimized);
  const GridImage& g = optimized->grid;
  const int i = static_cast<int>(std::floor((in_x - g.origin_x) / g.resolution));
  const int j = static_cast<int>(std::floor((in_y - g.origin_y) / g.resolution));
  if (i >= 0 && j >= 0 && i < g.width && j < g.height) {
    EXPECT_EQ(g.at(i, j), kUnknownCell);
  }
  EXPECT_FALSE(session.clearBox(Eigen::Vector3d(-1e7, 0, 0), hi, &cleared, &error)) << "outside the octree";
}

// A live tuner's impossible values (p_free above the prior, an upside-down band) are refused
// with the reason: the models and the band stay, and the map goes on as if nothing was asked.
TEST_F(MappingSessionTest, ReconfigureRefusesImpossibleValuesAndKeepsTheModels) {
  MappingSession session{MapperOptions(), SessionOptions()};
  Mapper plain;
  insertAll(&session, 0, 30);
  for (std::size_t k = 0; k < 30; ++k) ASSERT_TRUE(plain.insert((*scans_)[k]).ok());
  const std::uint64_t version = session.version();
  std::size_t unflushed = 0;  // what the insertion cache holds that the octree does not yet
  session.withMapper([&](Mapper& m) { unflushed = m.inserter().cache().dirtyCount(); });
  ASSERT_GT(unflushed, 0u);
  MapperOptions bad_model = session.mapperOptions();
  bad_model.insert.model.p_free = 0.9;
  std::string error;
  EXPECT_FALSE(session.reconfigure(bad_model, &error));
  EXPECT_NE(error.find("inverse sensor model"), std::string::npos) << error;
  MapperOptions bad_band = session.mapperOptions();
  std::swap(bad_band.slice.min_z, bad_band.slice.max_z);
  bad_band.slice.max_z -= 0.1;
  error.clear();
  EXPECT_FALSE(session.reconfigure(bad_band, &error));
  EXPECT_NE(error.find("slice"), std::string::npos) << error;
  EXPECT_EQ(session.version(), version) << "nothing changed";
  session.withMapper([&](Mapper& m) {
    EXPECT_EQ(m.inserter().cache().dirtyCount(), unflushed) << "a refused reconfigure wrote into the octree";
  });
  EXPECT_EQ(session.mapperOptions().insert.model.p_free, MapperOptions().insert.model.p_free);
  insertAll(&session, 30, 60);
  for (std::size_t k = 30; k < 60; ++k) ASSERT_TRUE(plain.insert((*scans_)[k]).ok());
  session.withMapper([&](Mapper& m) { test_support::expectSameTree(m.tree(), plain.tree()); });
}

}  // namespace

namespace {

// Through pruned leaves: a solid cube of occupied voxels (pruned into big leaves) cut by a box,
// voxel for voxel: none left inside, all kept outside (OctoMap's deleteNode aborts on this).
TEST(ClearBox, CutsThroughPrunedLeavesVoxelForVoxel) {
  octomap::OcTree cube(0.05);
  for (int n = 0; n < 4; ++n) {
    for (double x = 0.025; x < 1.6; x += 0.05)
      for (double y = 0.025; y < 1.6; y += 0.05)
        for (double z = 0.025; z < 0.8; z += 0.05) cube.updateNode(x, y, z, true, /*lazy_eval=*/true);
  }
  cube.updateInnerOccupancy();
  cube.prune();
  const std::size_t pruned_leaves = cube.getNumLeafNodes();
  ASSERT_LT(pruned_leaves, 32u * 32u * 16u) << "the cube is pruned";
  char tmpl[] = "/tmp/osm_cube_XXXXXX";
  const std::string path = std::string(::mkdtemp(tmpl)) + "/cube.ot";
  std::string error;
  ASSERT_TRUE(saveFullTree(cube, path, &error)) << error;
  Mapper mapper;
  ASSERT_TRUE(mapper.load(path, &error)) << error;
  const Eigen::Vector3d lo(0.31, 0.42, 0.11), hi(0.92, 1.33, 0.58);  // cuts through voxels: whole voxels go
  Mapper::Cleared cleared;
  ASSERT_TRUE(mapper.clearBox(lo, hi, &cleared, &error)) << error;
  EXPECT_GT(cleared.voxels, 0u);
  const octomap::OcTree& tree = mapper.tree();
  const octomap::OcTreeKey klo = tree.coordToKey(lo.x(), lo.y(), lo.z()), khi = tree.coordToKey(hi.x(), hi.y(), hi.z());
  std::size_t inside = 0, outside = 0;
  for (double x = 0.025; x < 1.6; x += 0.05) {
    for (double y = 0.025; y < 1.6; y += 0.05) {
      for (double z = 0.025; z < 0.8; z += 0.05) {
        const octomap::OcTreeKey k = tree.coordToKey(x, y, z);
        const bool in = k[0] >= klo[0] && k[0] <= khi[0] && k[1] >= klo[1] && k[1] <= khi[1] && k[2] >= klo[2] &&
                        k[2] <= khi[2];
        const octomap::OcTreeNode* node = tree.search(k);
        if (in) {
          ASSERT_EQ(node, nullptr) << x << " " << y << " " << z;
          ++inside;
        } else {
          ASSERT_NE(node, nullptr) << x << " " << y << " " << z;
          ASSERT_GT(node->getOccupancy(), 0.9);
          ++outside;
        }
      }
    }
  }
  EXPECT_GT(inside, 100u);
  EXPECT_GT(outside, 100u);
  // The tree's own bookkeeping holds: its node count is what a walk finds, and it saves and loads.
  std::size_t walked = 0;
  for (auto it = tree.begin_tree(); it != tree.end_tree(); ++it) ++walked;
  EXPECT_EQ(walked, tree.size());
  ASSERT_TRUE(saveFullTree(tree, path, &error)) << error;
  EXPECT_NE(loadTree(path, &error), nullptr) << error;
}

}  // namespace

namespace {

// A small wall of points 2 m in front of an origin, as a depth frame would give.
SensorCloud wallCloud() {
  SensorCloud cloud;
  cloud.origin = Eigen::Vector3d(0.0, 0.0, 0.3);
  for (int i = -20; i <= 20; ++i) {
    for (int k = 0; k <= 10; ++k) cloud.points.emplace_back(2.0f, 0.02f * i, 0.1f + 0.04f * k);
  }
  return cloud;
}

std::size_t occupiedLeaves(const octomap::OcTree& tree) {
  std::size_t n = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) n += tree.isNodeOccupied(*it);
  return n;
}

}  // namespace

TEST(CloudPreparation, GivesInsertPointsTreeAndIsRefusedAfterAReset) {
  const SensorCloud cloud = wallCloud();
  Mapper direct, prepared;
  ASSERT_TRUE(direct.insertPoints(cloud.origin, cloud.points).ok());
  std::unique_ptr<CloudPreparer> preparer = prepared.cloudPreparer();
  InsertResult result;
  ASSERT_TRUE(prepared.insertPrepared(preparer->prepare(cloud), preparer->mapGeneration(), &result));
  ASSERT_TRUE(result.ok());
  ASSERT_GT(occupiedLeaves(prepared.tree()), 0u);
  ASSERT_NO_FATAL_FAILURE(test_support::expectSameTree(direct.tree(), prepared.tree()));
  // Prepared before a reset: refused, the reset map untouched.
  PreparedCloud stale = preparer->prepare(cloud);
  prepared.reset();
  EXPECT_FALSE(prepared.insertPrepared(std::move(stale), preparer->mapGeneration(), &result));
  EXPECT_EQ(prepared.tree().getNumLeafNodes(), 0u);
  EXPECT_EQ(prepared.stats().clouds_inserted, 0u);
}

// The points a conversion left out (SensorCloud::left_out) are counted with the cloud's readings
// whichever way it goes in: directly, prepared, through the session, or inserted anew after a reset.
TEST(CloudPreparation, PointsTheConversionLeftOutAreCountedWithTheCloud) {
  SensorCloud cloud = wallCloud();
  cloud.points.emplace_back(std::nanf(""), 0.0f, 0.0f);  // one the core counts itself
  cloud.left_out[ReadingKind::kNaN] = 7;
  cloud.left_out[ReadingKind::kInfinite] = 2;
  const std::uint64_t hits = cloud.points.size() - 1;
  const auto expectCounted = [&](const ReadingCounts& r, const char* how) {
    EXPECT_EQ(r[ReadingKind::kNaN], 8u) << how;
    EXPECT_EQ(r[ReadingKind::kInfinite], 2u) << how;
    EXPECT_EQ(r[ReadingKind::kHit], hits) << how;
  };
  Mapper direct;
  expectCounted(direct.insert(cloud).readings, "Mapper::insert");
  expectCounted(direct.stats().cloud_points, "the mapper's totals");
  Mapper prepared;
  std::unique_ptr<CloudPreparer> preparer = prepared.cloudPreparer();
  InsertResult result;
  ASSERT_TRUE(prepared.insertPrepared(preparer->prepare(cloud), preparer->mapGeneration(), &result));
  expectCounted(result.readings, "prepared");
  MappingSession session(MapperOptions{}, SessionOptions{});
  expectCounted(session.insert(cloud).readings, "the session");
  expectCounted(session.withMapper([](const Mapper& m) { return m.stats().cloud_points; }), "the session's totals");
  // Prepared before a reset: the session inserts it anew, with its left-out points.
  std::unique_ptr<CloudPreparer> stale;
  session.refreshCloudPreparer(&stale);
  PreparedCloud before_reset = stale->prepare(cloud);
  session.reset();
  expectCounted(session.insertPrepared(std::move(before_reset), stale->mapGeneration(), cloud).readings,
                "inserted anew after a reset");
}

TEST_F(MappingSessionTest, CloudsPreparedOutsideTheLockAfterAResetStillGoIn) {
  MappingSession session(MapperOptions{}, SessionOptions{});
  EXPECT_EQ(session.cloudPreparerBytes(), 0u) << "no preparer before the first cloud";
  ASSERT_TRUE(session.insert(wallCloud()).ok());
  // The preparer's evidence window is memory the session holds besides the mapper's (reported).
  EXPECT_GT(session.cloudPreparerBytes(), 0u);
  session.reset();
  ASSERT_TRUE(session.insert(wallCloud()).ok());  // a new preparer for the new map
  EXPECT_EQ(session.withMapper([](const Mapper& m) { return m.stats().clouds_inserted; }), 1u);
  EXPECT_GT(session.withMapper([](Mapper& m) { return occupiedLeaves(m.tree()); }), 0u);
}
