// The session the node and octo_slice_map share: saving with and without the global pass, the
// octree lent to a save while scans go on, reset and load waiting for a save, versions.
#include "octo_slice_mapper/mapping_session.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <thread>

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

// A save writes what the Mapper's own save writes; with the pass, also the optimized set, and the
// pass's result goes into the map only when asked to.
TEST_F(MappingSessionTest, SaveWritesTheMapperSetAndWithThePassTheOptimizedSet) {
  SessionOptions options;
  options.write_optimized_into_map = false;
  MappingSession session(MapperOptions(), options);
  Mapper plain;
  insertAll(&session, 0, 60);
  for (std::size_t k = 0; k < 60; ++k) plain.insert((*scans_)[k]);

  SaveOutcome saved = session.save(dir_ + "/s", /*with_global_pass=*/false);
  ASSERT_TRUE(saved.ok) << saved.error;
  EXPECT_EQ(saved.files.size(), 5u);
  EXPECT_FALSE(saved.optimized);
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(plain.save(dir_ + "/p", &written, &error)) << error;
  EXPECT_EQ(bytesOf(dir_ + "/s.bt"), bytesOf(dir_ + "/p.bt"));
  EXPECT_EQ(bytesOf(dir_ + "/s.ot"), bytesOf(dir_ + "/p.ot"));

  const std::uint64_t changes = session.changes();
  saved = session.save(dir_ + "/o", /*with_global_pass=*/true);
  ASSERT_TRUE(saved.ok) << saved.error;
  ASSERT_TRUE(saved.optimized);
  EXPECT_TRUE(saved.optimized->report.converged);
  EXPECT_EQ(saved.files.size(), 9u);
  EXPECT_NE(::access((dir_ + "/o_optimized.bt").c_str(), F_OK), -1);
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
  auto tree = loadTree(dir_ + "/m.ot", &error);
  ASSERT_NE(tree, nullptr) << error;
  SliceGrid saved_slice(*tree, MapperOptions().slice);
  saved_slice.rebuild();
  EXPECT_EQ(saved_slice.knownCells(), known_at_save) << "the save is of the map when it started";
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

}  // namespace
