// bench_insertion_methods: ms per scan of the ways to put the same 2D lidar scans into a map, in
// one process, on the shared CARMEN datasets:
//   (a) octomap_server's method: free / occupied KeySets from computeRayKeys, then updateNode
//       with hit 0.7 / miss 0.4 per key;
//   (b) OcTree::insertPointCloud;
//   (c) a dense 2D float log-odds grid with Bresenham rays, the speed of light for this job;
//   (d) this project's insertion with its full inverse sensor model into the octree (ScanInserter),
//       and (d+) the node's Mapper, which also keeps the 2D slice and the scans for the global pass;
//   (e) a floor for any method that ends with an OcTree: only building (d)'s final map, every leaf
//       written once with its final value, in octree order (setValuesInTreeOrder), no scans at all;
//   (f) what (d) costs when finding the voxels and evaluating the model are free: each scan's
//       combined updates, worked out beforehand (not timed), applied through the layer cache with
//       updateNode's arithmetic, and the final flush: with this cache, a floor for any method that
//       gives (d)'s map by updating per scan, as exactness to updateNode requires;
//   (g) (d)'s tracing and model into a dense 2D float grid instead of the octree: the same
//       per-scan combined updates, applied with updateNode's arithmetic to a flat array. d/g is
//       what keeping the octree costs over a flat grid for the same sensor model.
//   (h) the reverse of (g): octomap_server's model (a) through this project's insertion path: the
//       rays of computeRayKeys (for level rays, the same walk with the same arithmetic in 2D) and
//       hit/miss, combined per scan in the dense evidence window (occupied wins, as (a)'s KeySets
//       do), applied through the layer cache, flushed at the end. It must give (a)'s octree, leaf
//       for leaf (checked). a/h and h/c: what our path gains over octomap_server's, and costs over
//       a flat grid, with octomap_server's model instead of ours.
// All get the same returns (readings below the range limit); (d)-(g) also clear along no-returns,
// which (a)-(c) and (h) are not given. Each repetition maps all scans into a fresh map with each
// method in turn; medians over repetitions.
//
//   bench_insertion_methods [--data DIR] [--repeats N] [--resolution M]... [--only intel|fr079]
#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/internal/scan_evidence.h"
#include "core/internal/scan_inserter_inspection.h"

namespace osm = octo_slice_mapper;
using Clock = std::chrono::steady_clock;

using osm::bench::CloudScan;
using osm::bench::insertLikeOctomapServer;
using osm::bench::median;

namespace {

// (c) A flat grid over the data's extent: log-odds floats, Bresenham, the same hit/miss and clamping.
class FlatGrid {
 public:
  FlatGrid(double min_x, double min_y, double max_x, double max_y, double resolution)
      : res_(resolution), x0_(min_x), y0_(min_y),
        w_(static_cast<int>(std::ceil((max_x - min_x) / resolution)) + 1),
        h_(static_cast<int>(std::ceil((max_y - min_y) / resolution)) + 1),
        cells_(std::size_t(w_) * h_, 0.0f) {}

  void insert(const CloudScan& scan) {
    const int ox = cellX(scan.origin.x()), oy = cellY(scan.origin.y());
    for (const octomap::point3d& p : scan.points) {
      const int ex = cellX(p.x()), ey = cellY(p.y());
      // Bresenham from the origin cell to the end cell; the end cell gets the hit.
      int x = ox, y = oy;
      const int dx = std::abs(ex - ox), dy = -std::abs(ey - oy), sx = ox < ex ? 1 : -1, sy = oy < ey ? 1 : -1;
      int err = dx + dy;
      while (x != ex || y != ey) {
        update(x, y, kMiss);
        const int e2 = 2 * err;
        if (e2 >= dy) err += dy, x += sx;
        if (e2 <= dx) err += dx, y += sy;
      }
      update(ex, ey, kHit);
    }
  }

 private:
  static constexpr float kHit = 0.8473f, kMiss = -0.4055f, kMin = -2.0f, kMax = 3.5f;
  int cellX(double x) const { return std::clamp(static_cast<int>((x - x0_) / res_), 0, w_ - 1); }
  int cellY(double y) const { return std::clamp(static_cast<int>((y - y0_) / res_), 0, h_ - 1); }
  void update(int x, int y, float l) {
    float& c = cells_[std::size_t(y) * w_ + x];
    c = std::min(kMax, std::max(kMin, c + l));
  }
  double res_, x0_, y0_;
  int w_, h_;
  std::vector<float> cells_;
};

// The clamping the node's Mapper gives its octree, for the trees (d)-(g) build without a Mapper.
void clampLikeTheMapper(octomap::OcTree* tree) { osm::useMapperThresholds(osm::MapperOptions{}, tree); }

// One scan's combined per-voxel updates, as (d) works them out, without applying them.
std::vector<osm::KeyUpdate> scanUpdates(osm::ScanInserter* tracer, const osm::Scan& s) {
  osm::ScanInserterInspection inspect(*tracer);
  return inspect.computeUpdates(s.sensor_pose.translation(), inspect.beamsOf(s, nullptr),
                                tracer->model().halfAngleFor(s.angle_increment));
}

// One scan's combined updates, which `for_each(fn)` hands to fn(key, log_odds), through `cache`
// as ScanInserter applies them: a level scan (`box` one layer thick) into its cached layer.
template <typename ForEach>
void applyThroughCache(osm::LayerCache* cache, const osm::KeyBox& box, ForEach for_each) {
  if (box.min[2] == box.max[2]) {
    osm::LayerCache::Layer& layer = cache->layer(box.min[2]);
    cache->cover(&layer, box.min[0], box.min[1], box.max[0], box.max[1]);
    for_each([&](const octomap::OcTreeKey& k, float l) { cache->apply(layer, k[0], k[1], l); });
  } else {
    for_each([&](const octomap::OcTreeKey& k, float l) { cache->apply(k, l); });
  }
}

// (f): each scan's combined updates from ScanInserter (not timed), then only their application
// through a LayerCache and the final flush (timed). ms per scan.
double applyOnly(const std::vector<osm::Scan>& scans, octomap::OcTree* tree) {
  osm::ScanInserter tracer(tree, osm::InsertOptions{});  // finds the updates; never applies any
  osm::LayerCache cache(tree);
  Clock::duration timed{};
  for (const osm::Scan& s : scans) {
    const std::vector<osm::KeyUpdate> updates = scanUpdates(&tracer, s);
    if (updates.empty()) continue;
    osm::KeyBox box;
    for (const osm::KeyUpdate& u : updates) box.add(u.key);
    const auto t0 = Clock::now();
    applyThroughCache(&cache, box, [&](auto&& fn) {
      for (const osm::KeyUpdate& u : updates) fn(u.key, u.log_odds);
    });
    timed += Clock::now() - t0;
  }
  const auto t0 = Clock::now();
  cache.flush();
  const Clock::duration flush = Clock::now() - t0;
  std::fprintf(stderr, "  (f): applying %.3f ms/scan, final flush %.3f ms/scan\n",
               std::chrono::duration<double, std::milli>(timed).count() / scans.size(),
               std::chrono::duration<double, std::milli>(flush).count() / scans.size());
  timed += flush;
  return std::chrono::duration<double, std::milli>(timed).count() / scans.size();
}

// Same leaves with the same log-odds (pruning is the same for the same values).
bool sameLeaves(const octomap::OcTree& a, const octomap::OcTree& b) {
  if (a.getNumLeafNodes() != b.getNumLeafNodes()) return false;
  for (auto it = a.begin_leafs(), end = a.end_leafs(); it != end; ++it) {
    const octomap::OcTreeNode* n = b.search(it.getKey(), it.getDepth());
    if (!n || n->getLogOdds() != it->getLogOdds()) return false;
  }
  return true;
}

// (g) A flat grid over a key rectangle that receives ScanInserter's combined updates with
// updateNode's arithmetic: no change at the bound the update pushes towards, else add and clamp.
// One layer: the logs' scans are level, so all of a scan's updates share the origin's z.
class FlatModelGrid {
 public:
  FlatModelGrid(const octomap::OcTree& tree, double min_x, double min_y, double max_x, double max_y)
      : kx0_(tree.coordToKey(min_x)), ky0_(tree.coordToKey(min_y)),
        w_(tree.coordToKey(max_x) - kx0_ + 1), h_(tree.coordToKey(max_y) - ky0_ + 1),
        lo_(tree.getClampingThresMinLog()), hi_(tree.getClampingThresMaxLog()), cells_(std::size_t(w_) * h_, 0.0f) {}

  void apply(const std::vector<osm::KeyUpdate>& updates) {
    for (const osm::KeyUpdate& u : updates) {
      const unsigned x = unsigned(u.key[0]) - kx0_, y = unsigned(u.key[1]) - ky0_;
      if (x >= w_ || y >= h_) {  // outside the rectangle: counted, so the caller can refuse the run
        ++outside_;
        continue;
      }
      float& c = cells_[std::size_t(y) * w_ + x];
      if ((u.log_odds >= 0.0f && c >= hi_) || (u.log_odds <= 0.0f && c <= lo_)) continue;
      c = std::min(hi_, std::max(lo_, c + u.log_odds));
    }
  }
  std::size_t outside() const { return outside_; }

 private:
  unsigned kx0_, ky0_, w_, h_;
  float lo_, hi_;
  std::vector<float> cells_;
  std::size_t outside_ = 0;
};

// (h) octomap_server's rays and hit/miss through our path: per-scan evidence window, layer cache.
class ServerModelThroughOurPath {
 public:
  explicit ServerModelThroughOurPath(octomap::OcTree* tree)
      : tree_(tree), cache_(tree), hit_(tree->getProbHitLog()), miss_(tree->getProbMissLog()) {}

  void insert(const CloudScan& scan) {
    const auto t0 = Clock::now();
    ++scans_;
    octomap::OcTreeKey origin, end;
    if (!tree_->coordToKeyChecked(scan.origin, origin)) return;
    osm::KeyBox box;
    box.add(origin);
    std::size_t max_adds = 0;  // the walk steps one key along one axis at a time
    for (const octomap::point3d& p : scan.points) {
      if (!tree_->coordToKeyChecked(p, end)) continue;
      box.add(end);
      for (int i = 0; i < 3; ++i) max_adds += std::abs(int(end[i]) - int(origin[i]));
      max_adds += 3;  // the origin, the end, and a step past the end that rounding may take
    }
    for (int i = 0; i < 2; ++i) --box.min[i], ++box.max[i];  // that step may leave the box by one
    if (!evidence_.begin(box, max_adds)) {  // the logs' scans are far below the window's limit
      std::fprintf(stderr, "bench_insertion_methods: (h) a scan's box is too large for the evidence window\n");
      std::exit(1);
    }
    for (const octomap::point3d& p : scan.points) {
      if (!tree_->coordToKeyChecked(p, end)) continue;
      if (p.z() == scan.origin.z()) {
        levelRay(scan.origin, p, origin, end);
      } else if (tree_->computeRayKeys(scan.origin, p, ray_)) {
        for (const octomap::OcTreeKey& k : ray_) evidence_.add(k, miss_);
      }
      evidence_.add(end, hit_);
    }
    const auto t1 = Clock::now();
    walking_ += t1 - t0;
    applyThroughCache(&cache_, box, [&](auto&& fn) { evidence_.drain(fn); });
    applying_ += Clock::now() - t1;
  }
  // Brings the octree up to date and reports where the time went (stderr).
  void flush() {
    const auto t0 = Clock::now();
    cache_.flush();
    const auto ms = [&](Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count() / scans_; };
    std::fprintf(stderr, "  (h): walking and recording %.3f ms/scan, applying %.3f ms/scan, final flush %.3f ms/scan\n",
                 ms(walking_), ms(applying_), ms(Clock::now() - t0));
  }

 private:
  // The free keys computeRayKeys gives for a ray within one z layer, by the same voxel walk
  // (Amanatides & Woo) with the same float/double arithmetic, in 2D: the z step never comes.
  void levelRay(const octomap::point3d& from, const octomap::point3d& to, const octomap::OcTreeKey& start,
                const octomap::OcTreeKey& end) {
    if (start == end) return;
    evidence_.add(start, miss_);
    octomap::point3d dir = to - from;
    const float length = static_cast<float>(dir.norm());
    dir /= length;
    int step[2];
    double t_max[2], t_delta[2];
    unsigned key[2] = {start[0], start[1]};
    for (int i = 0; i < 2; ++i) {
      step[i] = dir(i) > 0.0 ? 1 : dir(i) < 0.0 ? -1 : 0;
      if (step[i] == 0) {
        t_max[i] = t_delta[i] = std::numeric_limits<double>::max();
        continue;
      }
      double border = tree_->keyToCoord(key[i]);
      border += static_cast<float>(step[i] * tree_->getResolution() * 0.5);
      t_max[i] = (border - from(i)) / dir(i);
      t_delta[i] = tree_->getResolution() / std::fabs(dir(i));
    }
    while (true) {
      const int axis = t_max[0] < t_max[1] ? 0 : 1;
      key[axis] += step[axis];
      t_max[axis] += t_delta[axis];
      if (key[0] == end[0] && key[1] == end[1]) return;
      if (std::min(t_max[0], t_max[1]) > length) return;  // rounding walked past the end voxel
      evidence_.add(octomap::OcTreeKey(key[0], key[1], start[2]), miss_);
    }
  }

  octomap::OcTree* tree_;
  osm::LayerCache cache_;
  osm::ScanEvidence evidence_{osm::EvidenceCombining::kOccupiedWins};  // as (a)'s KeySets
  octomap::KeyRay ray_;
  float hit_, miss_;
  Clock::duration walking_{}, applying_{};
  std::size_t scans_ = 0;
};

double msPerScan(std::size_t scans, const std::function<void()>& run) {
  const auto t0 = Clock::now();
  run();
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / scans;
}

}  // namespace

int main(int argc, char** argv) {
  const char* env = std::getenv("OSM_DATA_DIR");
  std::string data = env && *env ? env : "../shared/data", only;
  int repeats = 3;
  std::vector<double> resolutions;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--data" && i + 1 < argc) data = argv[++i];
    else if (arg == "--repeats" && i + 1 < argc) repeats = std::max(1, std::atoi(argv[++i]));
    else if (arg == "--resolution" && i + 1 < argc) resolutions.push_back(std::atof(argv[++i]));
    else if (arg == "--only" && i + 1 < argc) only = argv[++i];
    else {
      std::fprintf(stderr, "usage: bench_insertion_methods [--data DIR] [--repeats N] [--resolution M]... [--only NAME]\n");
      return 2;
    }
  }
  if (resolutions.empty()) resolutions = {0.05, 0.02};
  const std::vector<std::pair<std::string, std::string>> datasets = {
      {"intel", data + "/intel_corrected/intel-corrected.log.gz"},
      {"fr079", data + "/fr079_corrected/freiburg-079-corrected.log.gz"}};
  std::printf("%-6s %5s | %9s %9s %9s %9s %9s %9s %9s %9s %9s | %7s %7s %7s %7s %7s %7s %7s %7s\n", "data",
              "res", "(a) srv", "(b) cloud", "(c) flat", "(d) ours", "(d+) node", "(e) floor", "(f) apply",
              "(g) flat+", "(h) srv+", "a/d", "d/c", "b/d", "e/c", "f/c", "d/g", "a/h", "h/c");
  for (const auto& [name, path] : datasets) {
    if (!only.empty() && only != name) continue;
    std::string error;
    std::vector<osm::Scan> scans;
    for (osm::LogScan& s : osm::readCarmenLog(path, {}, &error)) scans.push_back(std::move(s.scan));
    if (scans.empty()) {
      std::fprintf(stderr, "bench_insertion_methods: %s: %s\n", path.c_str(), error.c_str());
      return 1;
    }
    const std::vector<CloudScan> points = osm::bench::returnsAsClouds(scans);
    double min_x = 1e9, min_y = 1e9, max_x = -1e9, max_y = -1e9;
    for (const CloudScan& p : points) {
      for (const octomap::point3d& q : p.points) {
        min_x = std::min<double>(min_x, q.x()), max_x = std::max<double>(max_x, q.x());
        min_y = std::min<double>(min_y, q.y()), max_y = std::max<double>(max_y, q.y());
      }
    }
    for (double res : resolutions) {
      std::vector<double> a, b, c, d, dplus, e, f, g, h;
      for (int r = 0; r < repeats; ++r) {
        {
          octomap::OcTree tree(res);
          tree.setProbHit(0.7);
          tree.setProbMiss(0.4);
          a.push_back(msPerScan(scans.size(), [&] {
            for (const CloudScan& p : points) insertLikeOctomapServer(&tree, p);
          }));
          octomap::OcTree ours(res);
          ours.setProbHit(0.7);
          ours.setProbMiss(0.4);
          ServerModelThroughOurPath path(&ours);
          h.push_back(msPerScan(scans.size(), [&] {
            for (const CloudScan& p : points) path.insert(p);
            path.flush();
          }));
          if (!sameLeaves(ours, tree)) {
            std::fprintf(stderr, "bench_insertion_methods: (h) did not give (a)'s map (%zu leaves, (a) has %zu)\n",
                         ours.getNumLeafNodes(), tree.getNumLeafNodes());
            return 1;
          }
        }
        {
          octomap::OcTree tree(res);
          b.push_back(msPerScan(scans.size(), [&] {
            for (const CloudScan& p : points) tree.insertPointCloud(p.points, p.origin);
          }));
        }
        {
          FlatGrid grid(min_x - 1, min_y - 1, max_x + 1, max_y + 1, res);
          c.push_back(msPerScan(scans.size(), [&] {
            for (const CloudScan& p : points) grid.insert(p);
          }));
        }
        octomap::OcTree tree_d(res);
        {
          clampLikeTheMapper(&tree_d);
          osm::ScanInserter inserter(&tree_d, osm::InsertOptions{});
          d.push_back(msPerScan(scans.size(), [&] {
            for (const osm::Scan& s : scans) inserter.insert(s);
            inserter.flush();  // the octree brought up to date is part of the cost
          }));
          std::vector<osm::KeyUpdate> leaves;
          for (auto it = tree_d.begin_leafs(), end = tree_d.end_leafs(); it != end; ++it) {
            // Pruned blocks as their single voxels, so the floor builds the same map.
            const int size = 1 << (tree_d.getTreeDepth() - it.getDepth());
            const octomap::OcTreeKey k = it.getIndexKey();
            for (int dz = 0; dz < size; ++dz)
              for (int dy = 0; dy < size; ++dy)
                for (int dx = 0; dx < size; ++dx)
                  leaves.push_back({octomap::OcTreeKey(k[0] + dx, k[1] + dy, k[2] + dz), it->getLogOdds()});
          }
          octomap::OcTree rebuilt(res);
          clampLikeTheMapper(&rebuilt);
          e.push_back(msPerScan(scans.size(), [&] { osm::setValuesInTreeOrder(&rebuilt, &leaves); }));
          if (!sameLeaves(rebuilt, tree_d)) {
            std::fprintf(stderr, "bench_insertion_methods: (e) did not rebuild (d)'s map (%zu leaves, (d) has %zu)\n",
                         rebuilt.getNumLeafNodes(), tree_d.getNumLeafNodes());
            return 1;
          }
        }
        {
          octomap::OcTree applied(res);
          clampLikeTheMapper(&applied);
          f.push_back(applyOnly(scans, &applied));
          if (!sameLeaves(applied, tree_d)) {
            std::fprintf(stderr, "bench_insertion_methods: (f) did not give (d)'s map\n");
            return 1;
          }
        }
        {
          octomap::OcTree keys(res);  // the tracer's key arithmetic; nothing is written to it
          clampLikeTheMapper(&keys);
          osm::ScanInserter tracer(&keys, osm::InsertOptions{});
          // Our beams reach past the returns (no-return clearing, the model's margin behind a return).
          const double reach = tracer.options().model.no_return_clear_distance + 1.0;
          FlatModelGrid grid(keys, min_x - reach, min_y - reach, max_x + reach, max_y + reach);
          g.push_back(msPerScan(scans.size(), [&] {
            for (const osm::Scan& s : scans) {
              grid.apply(scanUpdates(&tracer, s));
            }
          }));
          if (grid.outside() > 0) {
            std::fprintf(stderr, "bench_insertion_methods: (g) %zu updates fell outside its grid\n", grid.outside());
            return 1;
          }
        }
        {
          osm::MapperOptions options;
          options.resolution = res;
          osm::Mapper mapper(options);
          dplus.push_back(msPerScan(scans.size(), [&] {
            for (const osm::Scan& s : scans) mapper.insert(s);
            mapper.tree();  // flushes the insertion cache into the octree
          }));
        }
        std::fprintf(stderr,
                     "  %s %.2f repeat %d/%d: a %.3f b %.3f c %.3f d %.3f d+ %.3f e %.3f f %.3f g %.3f h %.3f ms\n",
                     name.c_str(), res, r + 1, repeats, a.back(), b.back(), c.back(), d.back(), dplus.back(), e.back(),
                     f.back(), g.back(), h.back());
      }
      const double ma = median(a), mb = median(b), mc = median(c), md = median(d), mdp = median(dplus), me = median(e),
                   mf = median(f), mg = median(g), mh = median(h);
      std::printf(
          "%-6s %5.2f | %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f %9.3f | %6.1fx %6.2fx %6.1fx %6.2fx %6.2fx "
          "%6.2fx %6.1fx %6.2fx\n",
          name.c_str(), res, ma, mb, mc, md, mdp, me, mf, mg, mh, ma / md, md / mc, mb / md, me / mc, mf / mc, md / mg,
          ma / mh, mh / mc);
    }
  }
  std::printf("ms per scan, medians of %d; a/d: ours vs octomap_server (target >= 20x at 0.05 m); d/c: ours vs a "
              "flat grid (target <= 2x); e/c: building the final octree alone vs the whole flat-grid job; f/c: "
              "applying (d)'s updates and flushing, without finding them, vs the flat grid; d/g: ours vs the same "
              "tracing and model into a flat grid; a/h, h/c: octomap_server's model through our insertion path vs "
              "(a) and (c)\n",
              repeats);
  return 0;
}
