#include "octo_slice_mapper/octree_batch_update.h"

#include <cstdint>
#include <limits>

namespace octo_slice_mapper {
namespace {

// Morton code whose 3-bit groups, from the most significant, are OctoMap's child indices from
// the root down (x -> bit 0, y -> bit 1, z -> bit 2 of each group).
std::uint64_t treeOrder(const octomap::OcTreeKey& k) {
  auto spread = [](std::uint64_t v) {  // put bit i of a 16-bit value at bit 3i
    v = (v | (v << 16)) & 0x0000FF0000FFULL;
    v = (v | (v << 8)) & 0x00F00F00F00FULL;
    v = (v | (v << 4)) & 0x0C30C30C30C3ULL;
    v = (v | (v << 2)) & 0x249249249249ULL;
    return v;
  };
  return spread(k[0]) | (spread(k[1]) << 1) | (spread(k[2]) << 2);
}

}  // namespace

// LSD radix sort on the Morton codes. The keys of one scan share most high bits, so only the
// few bytes that differ are sorted (usually 3 of 6): far cheaper than a comparison sort.
void sortInTreeOrder(std::vector<KeyUpdate>* updates) {
  const std::size_t n = updates->size();
  std::vector<std::uint64_t> codes(n), codes_tmp(n);
  std::vector<KeyUpdate> tmp(n);
  std::uint64_t all_or = 0, all_and = ~std::uint64_t{0};
  for (std::size_t i = 0; i < n; ++i) {
    codes[i] = treeOrder((*updates)[i].key);
    all_or |= codes[i];
    all_and &= codes[i];
  }
  for (unsigned shift = 0; shift < 48; shift += 8) {
    if ((((all_or ^ all_and) >> shift) & 0xFF) == 0) continue;  // this byte is the same everywhere
    std::size_t count[257] = {0};
    for (std::size_t i = 0; i < n; ++i) ++count[((codes[i] >> shift) & 0xFF) + 1];
    for (int b = 0; b < 256; ++b) count[b + 1] += count[b];
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t dst = count[(codes[i] >> shift) & 0xFF]++;
      codes_tmp[dst] = codes[i];
      tmp[dst] = (*updates)[i];
    }
    codes.swap(codes_tmp);
    updates->swap(tmp);
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

// Mirrors OccupancyOcTreeBase::updateNodeRecurs for all updates of [begin, end), which all lie
// below `node` at `depth` and are in tree order.
void applyRecurs(const Batch& b, octomap::OcTreeNode* node, bool node_just_created, unsigned depth,
                 std::size_t begin, std::size_t end) {
  octomap::OcTree& tree = *b.tree;
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
  const unsigned bit = b.depth_max - 1 - depth;
  std::size_t i = begin;
  while (i < end) {
    const unsigned pos = octomap::computeChildIdx((*b.updates)[i].key, static_cast<int>(bit));
    std::size_t j = i + 1;
    while (j < end && octomap::computeChildIdx((*b.updates)[j].key, static_cast<int>(bit)) == pos) ++j;
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
  applySorted(tree, *values, true, nullptr);
}

void applyUpdatesOneByOne(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates) {
  for (const KeyUpdate& u : updates) tree->updateNode(u.key, u.log_odds);
}

}  // namespace octo_slice_mapper
