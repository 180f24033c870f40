// Saving survives being killed half-way and a full disk: the final name always holds a complete
// map, the old one or the new one, never a torso.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/sim/session.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

class AtomicSaveTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A map big enough that a save takes a while (the simulated office, ~400 kB as .ot).
    const sim::SimulatedSession session(sim::FloorPlan::office(), sim::SessionSpec::officeTour());
    small_ = new Mapper();
    big_ = new Mapper();
    const std::vector<Scan> scans = session.allScans();
    for (std::size_t k = 0; k < scans.size(); ++k) {
      if (k < 20) small_->insert(scans[k]);
      big_->insert(scans[k]);
    }
  }
  static void TearDownTestSuite() {
    delete small_;
    delete big_;
  }
  void SetUp() override {
    char tmpl[] = "/tmp/osm_atomic_XXXXXX";
    dir_ = ::mkdtemp(tmpl);
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }

  std::vector<std::string> tempFiles() const {
    std::vector<std::string> temps;
    for (const std::string& n : test_support::filesIn(dir_)) {
      if (n.find(".tmp-") != std::string::npos) temps.push_back(n);
    }
    return temps;
  }

  static Mapper* small_;
  static Mapper* big_;
  std::string dir_;
};
Mapper* AtomicSaveTest::small_ = nullptr;
Mapper* AtomicSaveTest::big_ = nullptr;

TEST_F(AtomicSaveTest, KilledHalfWayTheFinalNameStillHoldsACompleteMap) {
  const std::string path = dir_ + "/map.ot";
  std::string error;
  ASSERT_TRUE(saveFullTree(small_->tree(), path, &error)) << error;
  const std::size_t small_leaves = small_->tree().getNumLeafNodes(), big_leaves = big_->tree().getNumLeafNodes();
  ASSERT_NE(small_leaves, big_leaves);
  std::mt19937 rng(3);
  int interrupted = 0;
  for (int round = 0; round < 25; ++round) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {  // saves the big map over and over until killed
      std::string e;
      for (;;) {
        saveFullTree(big_->tree(), path, &e);
        saveFullTree(small_->tree(), path, &e);
      }
    }
    ::usleep(std::uniform_int_distribution<int>(2000, 40000)(rng));
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    auto loaded = loadTree(path, &error);
    ASSERT_NE(loaded, nullptr) << "round " << round << ": " << error;
    const std::size_t leaves = loaded->getNumLeafNodes();
    ASSERT_TRUE(leaves == small_leaves || leaves == big_leaves) << "round " << round << ": " << leaves << " leaves";
    const auto temps = tempFiles();
    if (!temps.empty()) ++interrupted;
    for (const std::string& t : temps) ::unlink((dir_ + "/" + t).c_str());
  }
  std::printf("[ kill during save ] %d of 25 kills landed mid-write; the map loaded complete every time\n", interrupted);
  EXPECT_GT(interrupted, 0) << "no kill hit a save in progress: the test proved nothing";
}

TEST_F(AtomicSaveTest, FullDiskFailsTheSaveAndKeepsThePreviousMap) {
  const std::string prefix = dir_ + "/map";
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(small_->save(prefix, &written, &error)) << error;
  const std::size_t small_leaves = small_->tree().getNumLeafNodes();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The disk is "full" after 64 kB: writes fail with EFBIG (SIGXFSZ ignored).
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit limit{64 * 1024, 64 * 1024};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    std::vector<std::string> files;
    std::string e;
    const bool saved = big_->save(prefix, &files, &e);
    std::fprintf(stderr, "[ full disk ] save: %s\n", saved ? "succeeded?!" : e.c_str());
    ::_exit(!saved && e.find("cannot write") != std::string::npos ? 0 : 1);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the save should have failed with a write error";
  // The whole previous set is kept, also the .bt, small enough to have fit: a set is written whole
  // or not at all.
  for (const char* ext : {".ot", ".bt"}) {
    auto loaded = loadTree(prefix + ext, &error);
    ASSERT_NE(loaded, nullptr) << ext << ": " << error;
    EXPECT_EQ(loaded->getNumLeafNodes(), small_leaves) << ext << ": the previous map is kept";
  }
  EXPECT_TRUE(tempFiles().empty()) << "a failed save removes its temporary file";
}

}  // namespace

// What a killed save leaves (PATH.tmp-XXXXXX) goes at the next save of that path, and all of a
// folder's at once (the node does that to maps_dir at start-up); other files stay.
TEST_F(AtomicSaveTest, TemporariesAKilledSaveLeftAreRemoved) {
  for (const char* name : {"m.ot.tmp-AbC123", "m.pgm.tmp-xyz789", "other.bt.tmp-111111", "m.ot.tmp-toolong7", "m.ot"}) {
    std::string error;
    ASSERT_TRUE(writeFileAtomically(dir_ + "/" + name, "left behind", &error)) << error;
  }
  std::vector<std::string> written;
  std::string error;
  ASSERT_TRUE(saveMapSet(small_->tree(), gridImageOf(small_->slice()), dir_ + "/m", &written, &error)) << error;
  std::vector<std::string> temps = tempFiles();
  std::sort(temps.begin(), temps.end());
  EXPECT_EQ(temps, (std::vector<std::string>{"m.ot.tmp-toolong7", "other.bt.tmp-111111"}))
      << "the save removes its own files' temporaries only";
  EXPECT_EQ(removeStaleTemporariesIn(dir_), 1u);
  EXPECT_EQ(tempFiles(), std::vector<std::string>{"m.ot.tmp-toolong7"}) << "not mkstemp's pattern: kept";
  EXPECT_NE(loadTree(dir_ + "/m.ot", &error), nullptr) << error;
}

// Every file of a set carries its save id; a set whose files come from two saves is reported (a
// kill between the renames can leave a new .bt/.ot/.pgm/.yaml beside the old .png).
TEST_F(AtomicSaveTest, AMixedSetIsDetected) {
  const std::string a = dir_ + "/a", b = dir_ + "/b";
  std::string error;
  ASSERT_TRUE(saveMapSet(small_->tree(), gridImageOf(small_->slice()), a, nullptr, &error)) << error;
  ASSERT_TRUE(saveMapSet(big_->tree(), gridImageOf(big_->slice()), b, nullptr, &error)) << error;
  const MapSetCheck whole = checkMapSet(b);
  ASSERT_EQ(whole.files.size(), 6u) << "PREFIX.{bt,ot,pcd,pgm,yaml,png}";
  EXPECT_FALSE(whole.mixed()) << whole.describe();
  const std::string id = whole.files.front().second;
  EXPECT_EQ(id.size(), 16u);
  EXPECT_NE(readSaveId(a + ".bt"), id) << "two different maps, two ids";
  // The stamped files still read as what they are, for our readers and OctoMap's.
  for (const char* ext : {".bt", ".ot"}) {
    auto tree = loadTree(b + ext, &error);
    ASSERT_NE(tree, nullptr) << ext << ": " << error;
    EXPECT_EQ(tree->getNumLeafNodes(), big_->tree().getNumLeafNodes()) << ext;
  }
  octomap::OcTree direct(0.1);
  EXPECT_TRUE(direct.readBinary(b + ".bt"));
  std::unique_ptr<octomap::AbstractOcTree> full(octomap::AbstractOcTree::read(b + ".ot"));
  ASSERT_NE(full, nullptr);
  EXPECT_EQ(full->size(), big_->tree().size());
  GridImage grid;
  ASSERT_TRUE(loadPgmYaml(b + ".yaml", &grid, &error)) << error;
  EXPECT_EQ(grid.width, gridImageOf(big_->slice()).width);
  // A save killed after renaming some files: b's .png replaced by a's.
  ASSERT_EQ(std::system(("cp " + a + ".png " + b + ".png").c_str()), 0);
  const MapSetCheck mixed = checkMapSet(b);
  EXPECT_TRUE(mixed.mixed());
  EXPECT_NE(mixed.describe().find("b.bt b.ot b.pcd b.pgm b.yaml are from save " + id), std::string::npos) << mixed.describe();
  EXPECT_NE(mixed.describe().find("b.png are from save " + readSaveId(a + ".png")), std::string::npos)
      << mixed.describe();
  EXPECT_EQ(mapSetPrefixOf(b + ".bt"), b);
  EXPECT_EQ(mapSetPrefixOf(b + ".ot"), b);
  EXPECT_EQ(mapSetPrefixOf(b + "_incremental.yaml"), b);
}

// Kills during set saves: every final name is a whole file, and checkMapSet calls a set mixed
// exactly when its files come from different saves.
TEST_F(AtomicSaveTest, KilledDuringSetSavesAMixIsAlwaysReported) {
  // The reference sets under the same name elsewhere: the .yaml names its .pgm.
  const std::string prefix = dir_ + "/m", reference = dir_ + "/ref/m";
  ASSERT_EQ(::mkdir((dir_ + "/ref").c_str(), 0755), 0);
  std::string error;
  std::map<std::string, std::pair<std::string, std::string>> versions;  // ext -> (small's bytes, big's bytes)
  for (const char* ext : {".bt", ".ot", ".pcd", ".pgm", ".yaml", ".png"}) versions[ext];
  ASSERT_TRUE(saveMapSet(small_->tree(), gridImageOf(small_->slice()), reference, nullptr, &error)) << error;
  for (auto& v : versions) ASSERT_TRUE(readFile(reference + v.first, &v.second.first, &error));
  ASSERT_TRUE(saveMapSet(big_->tree(), gridImageOf(big_->slice()), reference, nullptr, &error)) << error;
  for (auto& v : versions) ASSERT_TRUE(readFile(reference + v.first, &v.second.second, &error));
  ASSERT_TRUE(saveMapSet(small_->tree(), gridImageOf(small_->slice()), prefix, nullptr, &error)) << error;
  std::mt19937 rng(5);
  int mixes = 0;
  for (int round = 0; round < 30; ++round) {
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      std::string e;
      for (;;) {
        saveMapSet(big_->tree(), gridImageOf(big_->slice()), prefix, nullptr, &e);
        saveMapSet(small_->tree(), gridImageOf(small_->slice()), prefix, nullptr, &e);
      }
    }
    ::usleep(std::uniform_int_distribution<int>(2000, 60000)(rng));
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    std::set<int> sources;  // 0 small's, 1 big's
    for (const auto& v : versions) {
      std::string bytes;
      ASSERT_TRUE(readFile(prefix + v.first, &bytes, &error)) << error;
      ASSERT_TRUE(bytes == v.second.first || bytes == v.second.second) << "round " << round << ": " << v.first
                                                                        << " is neither whole save";
      sources.insert(bytes == v.second.second);
    }
    const MapSetCheck check = checkMapSet(prefix);
    EXPECT_EQ(check.mixed(), sources.size() > 1) << "round " << round << ": " << check.describe();
    mixes += sources.size() > 1;
  }
  std::printf("[ kill during set save ] %d of 30 kills left a mixed set; each was reported\n", mixes);
}
