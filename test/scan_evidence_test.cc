// ScanEvidence: per-scan combining of evidence against the rule written out with two floats.
#include "octo_slice_mapper/internal/scan_evidence.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <tuple>

#include "octo_slice_mapper/internal/octree_batch_update.h"

using namespace octo_slice_mapper;

namespace {
using KeyTuple = std::tuple<int, int, int>;
KeyTuple tupleOf(const octomap::OcTreeKey& k) { return {k[0], k[1], k[2]}; }

KeyBox boxOf(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi) {
  KeyBox box;
  box.add(lo);
  box.add(hi);
  return box;
}
}  // namespace

TEST(ScanEvidence, CodeIsExactAndOrdersByTheCombiningRule) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> dist(-3.0f, 3.0f);
  for (int i = 0; i < 10000; ++i) {
    const float a = dist(rng), b = i % 7 == 0 ? -a : dist(rng);
    if (a == 0.0f || b == 0.0f) continue;
    EXPECT_EQ(ScanEvidence::value(ScanEvidence::code(a)), a);
    // Which of the two the rule keeps: the larger positive, else the more negative.
    const float kept = (a > 0.0f || b > 0.0f) ? std::max(a, b) : std::min(a, b);
    EXPECT_EQ(ScanEvidence::value(std::max(ScanEvidence::code(a), ScanEvidence::code(b))), kept) << a << " " << b;
  }
  EXPECT_EQ(ScanEvidence::code(0.0f), 0u);
  EXPECT_EQ(ScanEvidence::code(-0.0f), 0u);
}

// Random evidence in a 3D box over several scans: drain() gives each voxel once, with the value
// the rule gives (the sum in add order; or the strongest occupied, else the strongest free), in
// first-touch order, and nothing of a scan survives into the next.
class ScanEvidenceBothRules : public ::testing::TestWithParam<EvidenceCombining> {};
INSTANTIATE_TEST_SUITE_P(Combining, ScanEvidenceBothRules,
                         ::testing::Values(EvidenceCombining::kSum, EvidenceCombining::kOccupiedWins));

TEST_P(ScanEvidenceBothRules, CombinesEachVoxelOncePerScan) {
  std::mt19937 rng(3);
  ScanEvidence evidence(GetParam());
  const bool sum = GetParam() == EvidenceCombining::kSum;
  struct Expected {
    float most_occupied = 0.0f, most_free = 0.0f, sum = 0.0f;
  };
  for (int scan = 0; scan < 5; ++scan) {
    const octomap::OcTreeKey lo(32000 + 10 * scan, 32100 - 7 * scan, 32760), hi(lo[0] + 40, lo[1] + 25, lo[2] + 2);
    ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 3000));
    std::map<KeyTuple, Expected> expected;
    std::vector<KeyTuple> order;
    std::uniform_int_distribution<int> dx(0, 40), dy(0, 25), dz(0, 2);
    std::uniform_real_distribution<float> value(-2.0f, 2.0f);
    for (int i = 0; i < 3000; ++i) {
      const octomap::OcTreeKey key(lo[0] + dx(rng), lo[1] + dy(rng), lo[2] + dz(rng));
      const float v = value(rng);
      if (v == 0.0f) continue;  // no evidence: callers do not add it
      evidence.add(key, v);
      auto [it, fresh] = expected.emplace(tupleOf(key), Expected{});
      if (fresh) order.push_back(tupleOf(key));
      it->second.most_occupied = std::max(it->second.most_occupied, v);
      it->second.most_free = std::min(it->second.most_free, v);
      it->second.sum += v;
    }
    if (sum) {  // a sum of exactly zero is no update
      order.erase(std::remove_if(order.begin(), order.end(), [&](const KeyTuple& k) { return expected[k].sum == 0.0f; }),
                  order.end());
    }
    std::vector<KeyTuple> drained;
    evidence.drain([&](const octomap::OcTreeKey& key, float update) {
      drained.push_back(tupleOf(key));
      const Expected& e = expected.at(tupleOf(key));
      EXPECT_EQ(update, sum ? e.sum : e.most_occupied > 0.0f ? e.most_occupied : e.most_free);
    });
    EXPECT_EQ(drained, order);
    evidence.drain([&](const octomap::OcTreeKey&, float) { ADD_FAILURE() << "drained twice"; });
  }
}

// A sum that comes back to exactly zero hands on no zero update, and later evidence for its voxel
// is handed on once.
TEST(ScanEvidence, ASumBackAtZeroHandsOnOnlyItsFinalValueOnce) {
  ScanEvidence evidence(EvidenceCombining::kSum);
  const octomap::OcTreeKey lo(1000, 1000, 32768), hi(1010, 1010, 32768), key(1005, 1005, 32768);
  const octomap::OcTreeKey other(1006, 1005, 32768);
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 4));
  evidence.add(key, 0.5f);
  evidence.add(other, 0.3f);
  evidence.add(key, -0.5f);
  evidence.add(key, 0.25f);
  std::vector<float> updates;
  evidence.drain([&](const octomap::OcTreeKey&, float update) { updates.push_back(update); });
  EXPECT_EQ(updates, (std::vector<float>{0.25f, 0.3f})) << "in the order the voxels were first touched";
  updates.clear();
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 2));
  evidence.add(key, 0.5f);
  evidence.add(key, -0.5f);
  evidence.drain([&](const octomap::OcTreeKey&, float update) { updates.push_back(update); });
  EXPECT_TRUE(updates.empty()) << "no zero update";
}

TEST(ScanEvidence, RefusesBoxesLargerThanItsLimit) {
  ScanEvidence evidence;
  const octomap::OcTreeKey lo(0, 0, 32768);
  EXPECT_FALSE(evidence.begin(boxOf(lo, octomap::OcTreeKey(4096, 4096, 32768)), 1));
  EXPECT_FALSE(evidence.begin(KeyBox{}, 1));
  EXPECT_TRUE(evidence.begin(boxOf(lo, octomap::OcTreeKey(4095, 4095, 32768)), 1));
}

// What the window reports holding counts the whole huge pages it maps, however small its box.
TEST(ScanEvidence, MemoryCountsTheWholePagesMapped) {
  ScanEvidence evidence;
  EXPECT_LT(evidence.memoryBytes(), std::size_t{1} << 20) << "nothing mapped yet";
  const octomap::OcTreeKey lo(1000, 1000, 32768), hi(1010, 1010, 32768);
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 10));  // 16 x 16 cells: 1 KiB of words
  const std::size_t one_page = evidence.memoryBytes();
  EXPECT_GE(one_page, std::size_t{2} << 20);
  EXPECT_LT(one_page, std::size_t{3} << 20);
  // A box of 2048 x 1024 cells (8 MiB of words): four pages.
  ASSERT_TRUE(evidence.begin(boxOf(octomap::OcTreeKey(0, 0, 32768), octomap::OcTreeKey(2047, 1023, 32768)), 10));
  EXPECT_GE(evidence.memoryBytes(), std::size_t{8} << 20);
  EXPECT_LT(evidence.memoryBytes(), std::size_t{9} << 20);
}

// A scan abandoned before drain() (its caller threw) leaves nothing behind for the next one.
TEST(ScanEvidence, AnAbandonedScanLeavesNothingBehind) {
  ScanEvidence evidence;
  const octomap::OcTreeKey lo(1000, 1000, 32768), hi(1010, 1010, 32768), key(1005, 1005, 32768);
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 10));
  evidence.add(key, 0.9f);
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 10));
  evidence.add(key, -0.4f);
  std::vector<float> updates;
  evidence.drain([&](const octomap::OcTreeKey&, float update) { updates.push_back(update); });
  EXPECT_EQ(updates, std::vector<float>{-0.4f});
}

// The window names its voxels by index for the walk (voxel_traversal.h): every key of the box
// has its own index, which names it back, and a step along an axis adds that axis's stride.
TEST(ScanEvidence, IndicesNameTheBoxsKeysAndStepByTheStrides) {
  ScanEvidence evidence;
  const octomap::OcTreeKey lo(32760, 40000, 32766), hi(32772, 40006, 32769);  // 13 x 7 x 4, not powers of two
  ASSERT_TRUE(evidence.begin(boxOf(lo, hi), 1));
  std::map<ScanEvidence::Index, KeyTuple> seen;
  for (int k = lo[2]; k <= hi[2]; ++k) {
    for (int j = lo[1]; j <= hi[1]; ++j) {
      for (int i = lo[0]; i <= hi[0]; ++i) {
        const octomap::OcTreeKey key(i, j, k);
        const ScanEvidence::Index index = evidence.indexOf(key);
        EXPECT_TRUE(seen.emplace(index, tupleOf(key)).second) << "two keys share index " << index;
        EXPECT_EQ(tupleOf(evidence.keyOf(index)), tupleOf(key));
        for (int axis = 0; axis < 3; ++axis) {
          octomap::OcTreeKey next = key;
          if (next[axis] == hi[axis]) continue;
          ++next[axis];
          EXPECT_EQ(evidence.indexOf(next), index + evidence.stride(axis));
          EXPECT_EQ(evidence.indexOf(key), evidence.indexOf(next) + (ScanEvidence::Index(0) - evidence.stride(axis)));
        }
      }
    }
  }
  // Evidence added by index is the key's: drain() hands it on under that key.
  const octomap::OcTreeKey key(32765, 40003, 32768);
  evidence.addAtAs<EvidenceCombining::kSum>(evidence.indexOf(key), 0.7f);
  std::vector<std::pair<KeyTuple, float>> updates;
  evidence.drain([&](const octomap::OcTreeKey& k, float update) { updates.emplace_back(tupleOf(k), update); });
  ASSERT_EQ(updates.size(), 1u);
  EXPECT_EQ(updates[0].first, tupleOf(key));
  EXPECT_EQ(updates[0].second, 0.7f);
}

// orderInTree() makes drain() hand on what a drain followed by sortInTreeOrder gives, value for
// value and in the same order: windows on either side of the tree's centre key (where every bit
// of the tree order differs) and across it, thin and thick, not on block boundaries, with sums
// that come back to zero (listed twice) and voxels given evidence many times; the same window
// reused scan after scan (its block masks must be left empty).
TEST_P(ScanEvidenceBothRules, OrderInTreeGivesWhatASortOfTheDrainGives) {
  std::mt19937 rng(11);
  ScanEvidence ordered(GetParam()), plain(GetParam());
  std::size_t compared = 0;
  for (int scan = 0; scan < 60; ++scan) {
    std::uniform_int_distribution<int> corner(32768 - 70, 32768 + 20), size(0, 60), thin(0, 3);
    octomap::OcTreeKey lo(corner(rng), corner(rng), corner(rng));
    octomap::OcTreeKey hi(lo[0] + size(rng), lo[1] + size(rng), lo[2] + (scan % 3 == 0 ? thin(rng) : size(rng)));
    const KeyBox box = boxOf(lo, hi);
    const std::size_t adds = 1 + rng() % 4000;
    ASSERT_TRUE(ordered.begin(box, adds));
    ASSERT_TRUE(plain.begin(box, adds));
    std::uniform_int_distribution<int> dx(0, hi[0] - lo[0]), dy(0, hi[1] - lo[1]), dz(0, hi[2] - lo[2]);
    std::uniform_real_distribution<float> value(-2.0f, 2.0f);
    for (std::size_t i = 0; i < adds; ++i) {
      const octomap::OcTreeKey key(lo[0] + dx(rng), lo[1] + dy(rng), lo[2] + dz(rng));
      float v = value(rng);
      if (v == 0.0f) continue;
      ordered.add(key, v);
      plain.add(key, v);
      if (i % 50 == 0) {  // the same again, negated: a sum back at zero
        ordered.add(key, -v);
        plain.add(key, -v);
      }
    }
    std::vector<KeyUpdate> expected, got;
    plain.drain([&](const octomap::OcTreeKey& k, float v) { expected.push_back({k, v}); });
    sortInTreeOrder(&expected);
    ordered.orderInTree();
    ordered.drain([&](const octomap::OcTreeKey& k, float v) { got.push_back({k, v}); });
    ASSERT_EQ(got.size(), expected.size()) << "scan " << scan;
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(tupleOf(got[i].key), tupleOf(expected[i].key)) << "scan " << scan << ", update " << i;
      ASSERT_EQ(got[i].log_odds, expected[i].log_odds) << "scan " << scan << ", update " << i;
    }
    compared += got.size();
  }
  EXPECT_GT(compared, 50000u);
}
