#include "core/internal/save_path.h"
#include "octo_slice_mapper/internal/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

using namespace octo_slice_mapper;

class SavePathTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/osm_save_path_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    root_ = tmpl;
    maps_ = root_ + "/maps";
    ::mkdir(maps_.c_str(), 0755);
    ::mkdir((maps_ + "/sub").c_str(), 0755);
    ::mkdir((root_ + "/elsewhere").c_str(), 0755);
    ASSERT_EQ(::symlink((root_ + "/elsewhere").c_str(), (maps_ + "/escape").c_str()), 0);
  }
  void TearDown() override { std::system(("rm -rf " + root_).c_str()); }
  std::string root_, maps_;
};

TEST_F(SavePathTest, RelativeAndInsidePathsAreAccepted) {
  std::string resolved, error;
  ASSERT_TRUE(resolveSavePrefix(maps_, "demo", false, &resolved, &error)) << error;
  EXPECT_EQ(resolved, maps_ + "/demo");
  ASSERT_TRUE(resolveSavePrefix(maps_, "sub/run1", false, &resolved, &error)) << error;
  EXPECT_EQ(resolved, maps_ + "/sub/run1");
  ASSERT_TRUE(resolveSavePrefix(maps_, maps_ + "/abs", false, &resolved, &error)) << error;
}

TEST_F(SavePathTest, EscapesAreRefused) {
  std::string resolved, error;
  EXPECT_FALSE(resolveSavePrefix(maps_, "../outside", false, &resolved, &error));
  EXPECT_NE(error.find("outside maps_dir"), std::string::npos) << error;
  EXPECT_FALSE(resolveSavePrefix(maps_, "/tmp/x", false, &resolved, &error));
  EXPECT_FALSE(resolveSavePrefix(maps_, "escape/x", false, &resolved, &error)) << "symlink out of maps_dir";
  EXPECT_FALSE(resolveSavePrefix(maps_, "sub/..", false, &resolved, &error));
  EXPECT_FALSE(resolveSavePrefix(maps_, "", false, &resolved, &error));
  EXPECT_FALSE(resolveSavePrefix(maps_, "nofolder/x", false, &resolved, &error));
}

TEST_F(SavePathTest, AllowAnyPathLiftsTheFence) {
  std::string resolved, error;
  ASSERT_TRUE(resolveSavePrefix(maps_, root_ + "/elsewhere/x", true, &resolved, &error)) << error;
  EXPECT_EQ(resolved, root_ + "/elsewhere/x");
}

// A newline in a prefix made a .yaml no YAML parser reads: control characters are refused.
TEST_F(SavePathTest, ControlCharactersAreRefused) {
  std::string resolved, error;
  for (const char* prefix : {"run\n1", "run\r", "tab\there", "bell\a"}) {
    EXPECT_FALSE(resolveSavePrefix(maps_, prefix, false, &resolved, &error)) << prefix;
    EXPECT_NE(error.find("control character"), std::string::npos) << error;
  }
  EXPECT_FALSE(resolveSavePrefix(maps_, "x\x7f", true, &resolved, &error));
  EXPECT_TRUE(resolveSavePrefix(maps_, "ünïcode run", false, &resolved, &error)) << error;
}

// The limit is the final names' (NAME_incremental.yaml within 255 characters), not the temporary
// files' (NAME_incremental.yaml.tmp-XXXXXX is cut to fit).
TEST_F(SavePathTest, PrefixLengthLimitIsTheFinalNames) {
  std::string resolved, error;
  EXPECT_TRUE(resolveSavePrefix(maps_, std::string(238, 'p'), false, &resolved, &error)) << error;
  EXPECT_FALSE(resolveSavePrefix(maps_, std::string(239, 'p'), false, &resolved, &error));
  EXPECT_NE(error.find("at most 238"), std::string::npos) << error;
  ASSERT_TRUE(resolveSavePrefix(maps_, std::string(238, 'p'), false, &resolved, &error));
  ASSERT_TRUE(writeFileAtomically(resolved + "_incremental.yaml", "image: x.pgm\n", &error)) << error;
  std::string back;
  ASSERT_TRUE(readFile(resolved + "_incremental.yaml", &back, &error)) << error;
  EXPECT_EQ(back, "image: x.pgm\n");
  // A killed save's temporary of that name (its stem cut to fit) goes at the next save.
  const std::string stale = maps_ + "/" + (std::string(238, 'p') + "_incremental.yaml").substr(0, 244) + ".tmp-AbC123";
  ASSERT_TRUE(writeFileAtomically(stale, "left", &error)) << error;
  EXPECT_EQ(removeStaleTemporaries(resolved + "_incremental.yaml"), 1u);
  EXPECT_NE(::access(stale.c_str(), F_OK), 0);
}
