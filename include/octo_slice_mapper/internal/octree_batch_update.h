// Applying many log-odds updates to an OcTree in one pass down the tree.
#pragma once

#include <octomap/OcTree.h>

#include <cstdint>
#include <vector>

namespace octo_slice_mapper {

struct KeyUpdate {
  octomap::OcTreeKey key;
  float log_odds;
};

// A voxel's log-odds before and after one update that changed it (`before` a NaN: it had none).
// The slice needs no other layer of the voxel's column to follow most such changes (SliceGrid).
struct VoxelChange {
  float before;
  float after;
};

// Gives the same tree as calling tree->updateNode(key, log_odds) for each update (same leaves,
// same log-odds, same clamping, same pruning), but sorts the updates in octree order first and
// walks each shared path from the root once, instead of twice per voxel (OctoMap's updateNode
// searches for the leaf, then descends again to change it). A node without children whose
// voxels would all end alike (at a clamping bound with no update leading away, or all updated
// with one value) is updated itself, without making and freeing its voxels. Keys must be unique.
// Reorders `updates`.
void applyUpdatesInTreeOrder(octomap::OcTree* tree, std::vector<KeyUpdate>* updates);

// A key's place in the octree's order: a Morton code whose 3-bit groups, from the most
// significant, are OctoMap's child indices from the root down (x -> bit 0, y -> bit 1, z -> bit 2
// of each group). Of keys below 2^k per axis it is below 2^(3k).
inline std::uint64_t treeOrder(const octomap::OcTreeKey& k) {
  auto spread = [](std::uint64_t v) {  // put bit i of a 16-bit value at bit 3i
    v = (v | (v << 16)) & 0x0000FF0000FFULL;
    v = (v | (v << 8)) & 0x00F00F00F00FULL;
    v = (v | (v << 4)) & 0x0C30C30C30C3ULL;
    v = (v | (v << 2)) & 0x249249249249ULL;
    return v;
  };
  return spread(k[0]) | (spread(k[1]) << 1) | (spread(k[2]) << 2);
}

// Puts updates in the order applySortedUpdates needs (a pure function of the keys: a cloud's
// updates are sorted while it is prepared, off the map's lock).
void sortInTreeOrder(std::vector<KeyUpdate>* updates);
// applyUpdatesInTreeOrder for updates already in that order; with `changes`, changes[i] is what
// updates[i] did to its voxel (before == after: nothing; the slice follows them, SliceGrid).
void applySortedUpdates(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates,
                        std::vector<VoxelChange>* changes = nullptr);

// Sets each key's log-odds to the given value (already within the clamping bounds), creating
// nodes as needed; the same tree as tree->setNodeValue(key, value) per key. Reorders `values`.
void setValuesInTreeOrder(octomap::OcTree* tree, std::vector<KeyUpdate>* values);
// setValuesInTreeOrder for values already in that order.
void setSortedValues(octomap::OcTree* tree, const std::vector<KeyUpdate>& values);

// The straightforward reference: updateNode per voxel, in the given order.
void applyUpdatesOneByOne(octomap::OcTree* tree, const std::vector<KeyUpdate>& updates);

}  // namespace octo_slice_mapper
