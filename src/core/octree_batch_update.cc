#include "octo_slice_mapper/internal/octree_batch_update.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>

namespace octo_slice_mapper {
namespace {

// LSD radix sort of n codes and their updates on the bytes that differ among them (`differing`),
// passing between (codes, updates) and the scratch arrays: true if the result ends in the scratch.
bool radixSort(std::uint64_t* codes, KeyUpdate* updates, std::uint64_t* codes_tmp, KeyUpdate* tmp, std::size_t n,
               std::uint64_t differing) {
  bool in_scratch = false;
  for (unsigned shift = 0; shift < 48; shift += 8) {
    if (((differing >> shift) & 0xFF) == 0) continue;  // this byte is the same everywhere
    std::size_t count[257] = {0};
    for (std::size_t i = 0; i < n; ++i) ++count[((codes[i] >> shift) & 0xFF) + 1];
    for (int b = 0; b < 256; ++b) count[b + 1] += count[b];
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t dst = count[(codes[i] >> shift) & 0xFF]++;
      codes_tmp[dst] = codes[i];
      tmp[dst] = updates[i];
    }
    std::swap(codes, codes_tmp);
    std::swap(updates, tmp);
    in_scratch = !in_scratch;
  }
  return in_scratch;
}

// Sorts n codes by value, with their updates; true if the result ends in the scratch arrays.
// Where the codes differ in more than three bytes, they are split by their highest differing bit
// first: keys on both sides of a power of two (a frame's floor at z = 0 straddles the tree's
// centre key) differ in every bit above it, but within each side in a few.
bool sortByCode(std::uint64_t* codes, KeyUpdate* updates, std::uint64_t* codes_tmp, KeyUpdate* tmp, std::size_t n) {
  std::uint64_t all_or = 0, all_and = ~std::uint64_t{0};
  for (std::size_t i = 0; i < n; ++i) all_or |= codes[i], all_and &= codes[i];
  const std::uint64_t differing = n < 2 ? 0 : all_or ^ all_and;
  unsigned bytes = 0;
  for (unsigned shift = 0; shift < 48; shift += 8) bytes += ((differing >> shift) & 0xFF) != 0;
  if (bytes <= 3) return radixSort(codes, updates, codes_tmp, tmp, n, differing);
  const std::uint64_t top = std::uint64_t{1} << (63 - __builtin_clzll(differing));
  std::size_t zeros = 0;  // a stable split into the scratch: those without the bit first
  for (std::size_t i = 0; i < n; ++i) zeros += (codes[i] & top) == 0;
  std::size_t lo = 0, hi = zeros;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t dst = (codes[i] & top) ? hi++ : lo++;
    codes_tmp[dst] = codes[i];
    tmp[dst] = updates[i];
  }
  // Each side sorted from the scratch; both must end in the same arrays.
  const bool low_back = sortByCode(codes_tmp, tmp, codes, updates, zeros);
  const bool high_back = sortByCode(codes_tmp + zeros, tmp + zeros, codes + zeros, updates + zeros, n - zeros);
  if (low_back != high_back) {  // move the high side next to the low one
    std::uint64_t* from_codes = high_back ? codes + zeros : codes_tmp + zeros;
    KeyUpdate* from = high_back ? updates + zeros : tmp + zeros;
    std::copy(from_codes, from_codes + (n - zeros), (high_back ? codes_tmp : codes) + zeros);
    std::copy(from, from + (n - zeros), (high_back ? tmp : updates) + zeros);
  }
  return !low_back;  // the low side's result is in the scratch unless it came back
}

}  // namespace

// Radix sort on the Morton codes. The keys of one scan share most high bits, so only the few
// bytes that differ are sorted (usually 3 of 6): far cheaper than a comparison sort.
void sortInTreeOrder(std::vector<KeyUpdate>* updates) {
  const std::size_t n = updates->size();
  // Scratch left uninitialised (as vectors, its 28 bytes per update were zeroed first for nothing).
  const std::unique_ptr<std::uint64_t[]> codes(new std::uint64_t[n]), codes_tmp(new std::uint64_t[n]);
  const std::unique_ptr<KeyUpdate[]> tmp(new KeyUpdate[n]);
  for (std::size_t i = 0; i < n; ++i) codes[i] = treeOrder((*updates)[i].key);
  if (sortByCode(codes.get(), updates->data(), codes_tmp.get(), tmp.get(), n)) {
    std::copy(tmp.get(), tmp.get() + n, updates->begin());
  }
}

namespace {

struct Batch {
  octomap::OcTree* tree;
  const std::vector<KeyUpdate>* updates;
  unsigned depth_max;
  bool set;  // log_odds are values to set, not to add
  std::vector<VoxelChange>* changes;  // per update, or null
};

// Updates [begin, end) below a node above the voxels' depth that holds no children (pruned: each
// voxel below holds its value; or just created) and would hold none afterwards either: applied to
// the node itself, without creating and freeing its voxels (malloc and free, all of them here,
// were 3.5 % of the depth-frame benchmark's samples). Two cases, both exact (each voxel's value
// is the node's, so each would end as the node does):
//  - the node sits at a clamping bound and no update leads away from it: nothing changes (what
//    OctoMap's updateNode does per voxel, its early abort);
//  - the updates cover every voxel below it with one value (in tree order, unique keys: as many
//    updates as voxels).
// False (nothing done) otherwise.
bool applyToChildlessNode(const Batch& b, octomap::OcTreeNode* node, bool node_just_created, unsigned depth,
                          std::size_t begin, std::size_t end) {
  const std::vector<KeyUpdate>& u = *b.updates;
  const float value = node->getLogOdds();
  const bool at_min = !node_just_created && value <= b.tree->getClampingThresMinLog();
  const bool at_max = !node_just_created && value >= b.tree->getClampingThresMaxLog();
  if (at_min || at_max) {
    std::size_t i = begin;
    while (i < end && (at_min ? u[i].log_odds <= 0.0f : u[i].log_odds >= 0.0f)) ++i;
    if (i == end) {
      if (b.changes) std::fill(b.changes->begin() + begin, b.changes->begin() + end, VoxelChange{value, value});
      return true;
    }
  }
  const unsigned levels = b.depth_max - depth;
  if (end - begin != std::size_t{1} << (3 * levels)) return false;
  const float update = u[begin].log_odds;
  for (std::size_t i = begin + 1; i < end; ++i) {
    if (u[i].log_odds != update) return false;
  }
  const float before = node_just_created ? std::numeric_limits<float>::quiet_NaN() : value;
  b.tree->updateNodeLogOdds(node, update);
  if (b.changes) {
    std::fill(b.changes->begin() + begin, b.changes->begin() + end, VoxelChange{before, node->getLogOdds()});
  }
  return true;
}

// Mirrors OccupancyOcTreeBase::updateNodeRecurs for all updates of [begin, end), which all lie
// below `node` at `depth` and are in tree order.
void applyRecurs(const Batch& b, octomap::OcTreeNode* node, bool node_just_created, unsigned depth,
                 std::size_t begin, std::size_t end) {
  octomap::OcTree& tree = *b.tree;
  if (depth < b.depth_max && !b.set && (node_just_created || !tree.nodeHasChildren(node)) &&
      applyToChildlessNode(b, node, node_just_created, depth, begin, end)) {
    return;
  }
  if (depth == b.depth_max) {
    const float before = node_just_created ? std::numeric_limits<float>::quiet_NaN() : node->getLogOdds();
    if (b.set) {
      node->setLogOdds((*b.updates)[begin].log_odds);
    } else {
      tree.updateNodeLogOdds(node, (*b.updates)[begin].log_odds);
    }
    if (b.changes) (*b.changes)[begin] = {before, node->getLogOdds()};
    return;
  }
  const int bit = static_cast<int>(b.depth_max - 1 - depth);
  const std::vector<KeyUpdate>& u = *b.updates;
  std::size_t i = begin;
  while (i < end) {
    const unsigned pos = octomap::computeChildIdx(u[i].key, bit);
    // The end of this child's updates: in tree order the child index never falls within a node,
    // so the end is found by galloping and bisection (near the root every update goes to one
    // child, and a scan past all of them per level was a third of applying a depth frame).
    std::size_t j = i + 1;
    if (j < end && octomap::computeChildIdx(u[j].key, bit) == pos) {
      std::size_t step = 1, lo = j;  // u[lo] is this child's
      while (lo + step < end && octomap::computeChildIdx(u[lo + step].key, bit) == pos) lo += step, step *= 2;
      std::size_t hi = std::min(lo + step, end);  // the first past lo not known to be this child's
      while (hi - lo > 1) {
        const std::size_t mid = lo + (hi - lo) / 2;
        (octomap::computeChildIdx(u[mid].key, bit) == pos ? lo : hi) = mid;
      }
      j = hi;
    }
    bool created = false;
    if (!tree.nodeChildExists(node, pos)) {
      if (!tree.nodeHasChildren(node) && !node_just_created) {
        tree.expandNode(node);  // a pruned node: its children inherit its value
      } else {
        tree.createNodeChild(node, pos);
        created = true;
      }
    }
    applyRecurs(b, tree.getNodeChild(node, pos), created, depth + 1, i, j);
    i = j;
  }
  if (!tree.pruneNode(node)) node->updateOccupancyChildren();
}

// `updates` in tree order.
void applySorted(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates, bool set,
                 std::vector<VoxelChange>* changes) {
  if (changes) changes->resize(updates.size());
  if (updates.empty()) return;
  std::size_t first = 0;
  if (!tree->getRoot()) {
    // Only updateNode / setNodeValue can create the root; the rest then goes below it.
    const KeyUpdate& u = updates[0];
    const octomap::OcTreeNode* node = set ? tree->setNodeValue(u.key, u.log_odds) : tree->updateNode(u.key, u.log_odds);
    if (changes) (*changes)[0] = {std::numeric_limits<float>::quiet_NaN(), node->getLogOdds()};
    first = 1;
  }
  if (first < updates.size()) {
    const Batch batch{tree, &updates, tree->getTreeDepth(), set, changes};
    applyRecurs(batch, tree->getRoot(), false, 0, first, updates.size());
  }
}

}  // namespace

void applyUpdatesInTreeOrder(octomap::OcTree* tree, std::vector<KeyUpdate>* updates) {
  sortInTreeOrder(updates);
  applySorted(tree, *updates, false, nullptr);
}

void applySortedUpdates(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates,
                        std::vector<VoxelChange>* changes) {
  applySorted(tree, updates, false, changes);
}

void setValuesInTreeOrder(octomap::OcTree* tree, std::vector<KeyUpdate>* values) {
  sortInTreeOrder(values);
  setSortedValues(tree, *values);
}

void setSortedValues(octomap::OcTree* tree, const std::vector<KeyUpdate>& values) {
  applySorted(tree, values, true, nullptr);
}

void applyUpdatesOneByOne(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates) {
  for (const KeyUpdate& u : updates) tree->updateNode(u.key, u.log_odds);
}

}  // namespace octo_slice_mapper
