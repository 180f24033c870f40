// octo_slice_map: offline mapping of a recorded log (CARMEN .log/.clf, gzip or plain) or rosbag.
//
//   octo_slice_map LOG [options]
//   octo_slice_map --bag FILE [--scan-topic scan]... [--cloud-topic TOPIC]... [--fixed-frame odom]
//                  [--floor-base-frame base_footprint] [options]
//
// --cloud-topic maps a bag's PointCloud2 messages (a depth camera's) into the same octree, in the
// bag's order with the scans; --scan-topic "" maps the clouds alone. Both may be given more than
// once (a robot's several lidars and cameras, each in its own frame).
//
// Writes PREFIX.{bt,ot,pcd,pgm,yaml,png}, the best map (the global pass's; the incremental map with
// --no-optimize), and PREFIX_incremental.{pgm,yaml,png}, the incremental slice, and prints a
// one-line JSON summary on stdout. Progress goes to stderr when it is a terminal.
#include <ros/package.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bag_scans.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/cloud_pipeline.h"
#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/mapping_session.h"
#include "core/internal/memory_reuse.h"
#include "octo_slice_mapper/option_table.h"
#include "octo_slice_mapper/slice_grid.h"
#include "progress_bar.h"
#include "ros/tf_lookup.h"

namespace osm = octo_slice_mapper;
using Clock = std::chrono::steady_clock;

namespace {

struct Args {
  std::string log, bag, fixed_frame = "odom", floor_base_frame = "auto", out;
  std::vector<std::string> scan_topics = {"scan"}, cloud_topics;  // "" in either: none
  bool hasCloudTopic() const {
    return std::any_of(cloud_topics.begin(), cloud_topics.end(), [](const std::string& t) { return !t.empty(); });
  }
  bool hasScanTopic() const {
    return std::any_of(scan_topics.begin(), scan_topics.end(), [](const std::string& t) { return !t.empty(); });
  }
  bool optimize = true, warm_start = true;  // warm: the better start on every shared log (doc/benchmarks.md)
  int holdout_every = 0;
  osm::MapperOptions mapper;
  osm::CarmenLogOptions carmen;
};

// The names the tool had before the option table named every option once; kept for scripts.
const std::map<std::string, std::string> kOldFlags = {{"no_return_clear_distance", "--no-return-clear"},
                                                      {"evidence_combining", "--combine"},
                                                      {"forward_z_hit", "--z-hit"},
                                                      {"forward_z_rand", "--z-rand"},
                                                      {"forward_z_miss", "--z-miss"}};

// Every mapper option of the table as --name-with-dashes; booleans as a flag and its --no- form.
void addMapperOptions(CLI::App* app, osm::MapperOptions* options) {
  for (const auto& spec : osm::mapperOptionTable()) {
    std::string names = osm::optionFlag(spec.name);
    const auto old = kOldFlags.find(spec.name);
    if (old != kOldFlags.end()) names += "," + old->second;
    std::string doc = spec.doc;
    if (*spec.unit) doc += " (" + std::string(spec.unit) + ")";
    const osm::OptionField field = spec.field(*options);
    if (auto* b = std::get_if<bool*>(&field)) {
      app->add_flag(names + ",!--no-" + osm::optionFlag(spec.name).substr(2), **b, doc + " [" + (**b ? "on" : "off") + "]");
    } else if (auto* c = std::get_if<osm::EvidenceCombining*>(&field)) {
      osm::EvidenceCombining* combining = *c;
      app->add_option_function<std::string>(
             names, [combining](const std::string& name) { osm::evidenceCombiningFromName(name, combining); }, doc)
          ->check(CLI::IsMember({"sum", "occupied_wins"}))
          ->default_str(osm::optionValueText(field));
    } else {
      std::visit([&](auto* value) { app->add_option(names, *value, doc)->default_str(osm::optionValueText(field)); },
                 field);
    }
  }
}

// False (and the exit code in `code`) when the program should stop: --help or a bad command line.
bool parse(int argc, char** argv, Args* a, int* code) {
  // Nobody reads the octree until the end: one flush then writes each voxel once, instead of
  // rewriting the voxels that keep changing every 20 000 updates.
  a->mapper.max_unflushed_voxels = std::size_t{1} << 26;
  CLI::App app{"octo_slice_map: offline mapping of a recorded CARMEN log or rosbag. Writes PREFIX.{bt,ot,pcd,pgm,yaml,png} "
               "(the global pass's map; with --no-optimize the incremental one) and PREFIX_incremental.{pgm,yaml,png}, "
               "and prints a one-line JSON summary."};
  app.add_option("log", a->log, "CARMEN log (.log/.clf, plain or .gz): FLASER, RLASER, ROBOTLASER1 records");
  app.add_option("--bag", a->bag, "a rosbag instead of a log");
  app.add_option("--scan-topic", a->scan_topics, "the bag's LaserScan topic; again for each further lidar (\"\": none)")
      ->capture_default_str()
      ->allow_extra_args(false);
  app.add_option("--cloud-topic", a->cloud_topics,
                 "the bag's PointCloud2 topic (a depth camera), mapped too; again for each further camera. With one, "
                 "the slice's band defaults to the navigation band, 0.05-0.80 m above the floor")
      ->allow_extra_args(false);
  app.add_option("--fixed-frame", a->fixed_frame, "the bag's fixed frame")->capture_default_str();
  app.add_option("--floor-base-frame", a->floor_base_frame,
                 "a frame whose origin lies on the floor the robot stands on: each depth frame's floor is the one "
                 "through it; auto: base_footprint where the bag's tf has it (REP 120), else none; '': none (the "
                 "floor found from the points alone)")
      ->capture_default_str();
  app.add_option("--out", a->out, "output prefix (default: the package's maps/<log name>)");
  app.add_option("--laser-z", a->carmen.laser_z, "height given to 2D log scans (m)")->capture_default_str();
  app.add_flag("--optimize,!--no-optimize", a->optimize,
               "run the global pass and save its map as PREFIX.* (the default; --no-optimize: only the incremental map, "
               "when only speed matters)");
  app.add_flag_callback("--warm-start", [a] { a->optimize = a->warm_start = true; }, "the default start; kept for scripts");
  app.add_flag_callback("--cold-start", [a] { a->optimize = true, a->warm_start = false; },
                        "the global pass from all-free (the lab's start)");
  app.add_option("--holdout-every", a->holdout_every,
                 "keep every Nth scan from index 5 out of the maps; score both maps on them as exported")
      ->check(CLI::NonNegativeNumber);
  addMapperOptions(&app, &a->mapper);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    *code = app.exit(e) == 0 ? 0 : 2;
    return false;
  }
  // With a depth camera the slice is the navigation band, 0.05-0.80 m above the floor, unless a
  // band is given: the camera is there to see what the lidar's plane misses (as mapping.launch
  // camera:=true).
  if (a->hasCloudTopic()) {
    if (app.count("--slice-min-z") == 0) a->mapper.slice.min_z = osm::kNavigationBandMinZ;
    if (app.count("--slice-max-z") == 0) a->mapper.slice.max_z = osm::kNavigationBandMaxZ;
  }
  if (a->log.empty() == a->bag.empty()) {
    std::cerr << "octo_slice_map: give either a CARMEN log or --bag FILE (--help lists the options)\n";
    *code = 2;
    return false;
  }
  if (a->out.empty()) {
    std::string stem = a->log.empty() ? a->bag : a->log;
    stem = stem.substr(stem.find_last_of('/') + 1);
    for (const char* ext : {".gz", ".log", ".clf", ".bag"}) {
      const std::string e = ext;
      if (stem.size() > e.size() && stem.compare(stem.size() - e.size(), e.size(), e) == 0) stem.resize(stem.size() - e.size());
    }
    const std::string package = ros::package::getPath("octo_slice_mapper");
    a->out = package.empty() ? stem : package + "/maps/" + stem;
  }
  return true;
}

double peakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024.0;  // Linux reports kB
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out + "\"";
}

std::string jsonScore(const osm::HeldOutScore& e) {
  std::ostringstream j;
  j << "{\"beams\": " << e.beams << ", \"within_10cm\": " << e.within_10cm << ", \"within_25cm\": " << e.within_25cm
    << ", \"mean_abs_error_m\": " << e.mean_abs_error << ", \"median_abs_error_m\": " << e.median_abs_error
    << ", \"too_short\": " << e.too_short << ", \"too_long\": " << e.too_long
    << ", \"unknown_first\": " << e.unknown_first << "}";
  return j.str();
}

// Bytes per observed 2D cell (a known slice cell) of the octree and of the slice grid.
// `cloud_preparer`: the evidence windows that prepare clouds besides the mapper's own (0 without clouds).
std::string jsonMemory(osm::Mapper& mapper, std::size_t cloud_preparer) {
  const double cells = std::max<std::size_t>(1, mapper.slice().knownCells());
  const std::size_t octree = mapper.tree().memoryUsage();
  const std::size_t slice = mapper.slice().memoryBytes();
  const std::size_t cache = mapper.inserter().memoryBytes();
  std::ostringstream j;
  j << "{\"octree_bytes\": " << octree << ", \"slice_bytes\": " << slice << ", \"insertion_cache_bytes\": " << cache
    << ", \"cloud_preparer_bytes\": " << cloud_preparer << ", \"octree_bytes_per_cell\": " << octree / cells
    << ", \"slice_bytes_per_cell\": " << slice / cells << ", \"insertion_cache_bytes_per_cell\": " << cache / cells
    << "}";
  return j.str();
}

// What mapping the input gave besides the map: the held-out scans, counts, timings, problems.
struct Intake {
  std::vector<osm::Scan> held_out;
  std::size_t scans_read = 0, beams = 0;
  double insert_seconds = 0.0, cloud_seconds = 0.0;
  std::map<std::string, std::size_t> skipped_scans;
  std::size_t refused_reported = 0;
  std::size_t bad_lines = 0;
  std::string end_error;  // a log that ended early (truncated gzip)
  std::size_t cloud_preparer_bytes = 0;  // the pipeline's windows for preparing clouds
  // Clouds read from a bag, and those with a ground point (--floor-base-frame placed by tf).
  std::size_t clouds_read = 0, clouds_with_ground = 0;
};

// Feeds scans and clouds to the session, holding out every Nth scan and reporting refused ones.
// With clouds, everything goes through a CloudPipeline (frames prepared in parallel, scans and
// clouds applied in the input's order: the map is the one of inserting them one by one).
class Feeder {
 public:
  Feeder(const Args& args, osm::MappingSession* session, Intake* intake)
      : args_(args), session_(session), intake_(intake) {
    if (args.hasCloudTopic()) pipeline_ = std::make_unique<osm::CloudPipeline>(session, 0, /*max_pending=*/8);
  }

  // `where`: the log and line (or bag message) the scan came from, for the report of a refused one.
  void scan(const osm::Scan& scan, const std::string& where) {
    const bool hold = osm::HoldOut{args_.holdout_every, 5}.holds(intake_->scans_read);
    ++intake_->scans_read;
    if (hold) {
      intake_->held_out.push_back(scan);
      return;
    }
    const std::size_t beams = scan.ranges.size();
    insert(scan, &intake_->insert_seconds, "invalid_scan", "scan", where,
           [this, beams] { intake_->beams += beams; });
  }
  void cloud(const osm::DeferredCloud& cloud) {
    insert(cloud, &intake_->cloud_seconds, "cloud_invalid", "cloud", args_.bag, [] {});
  }
  // Waits for what the pipeline still holds (call before reading the map).
  void finish() {
    if (!pipeline_) return;
    pipeline_->wait();
    intake_->cloud_preparer_bytes = pipeline_->memoryBytes();
  }

 private:
  // One scan or cloud into the session (through the pipeline, when there is one), timed; a
  // refused one is counted under `reason` and reported (the first 20); `ok` runs for one inserted.
  template <typename Item, typename Ok>
  void insert(const Item& item, double* seconds, const char* reason, const char* what, const std::string& where, Ok ok) {
    if (pipeline_) {
      // The callbacks run one at a time, in order, on the pipeline's workers.
      pipeline_->submit(Item(item), [=](const osm::CloudPipeline::Outcome& o) {
        *seconds += o.work_seconds;
        if (o.result.ok()) ok();
        else refused(o.result, reason, what, where);
      });
      return;
    }
    const auto t0 = Clock::now();
    const osm::InsertResult result = session_->insert(made(item, session_->mapperOptions().insert.cloud_flying_pixels));
    *seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    if (result.ok()) ok();
    else refused(result, reason, what, where);
  }
  // What a session inserts: a scan as it is, a deferred cloud with its points made.
  static const osm::Scan& made(const osm::Scan& scan, const osm::FlyingPixelOptions&) { return scan; }
  static osm::SensorCloud made(const osm::DeferredCloud& deferred, const osm::FlyingPixelOptions& flying) {
    return deferred.made(flying);
  }
  void refused(const osm::InsertResult& result, const char* reason, const char* what, const std::string& where) {
    intake_->skipped_scans[reason]++;
    if (++intake_->refused_reported <= 20) {
      std::cerr << "octo_slice_map: " << where << ": " << what << " skipped: " << result.error << "\n";
    }
    if (intake_->refused_reported == 21) std::cerr << "octo_slice_map: (further skipped scans and clouds are only counted)\n";
  }

  const Args& args_;
  osm::MappingSession* session_;
  Intake* intake_;
  std::unique_ptr<osm::CloudPipeline> pipeline_;
};

// A CARMEN log through `feed`; 0, or the exit status when the log cannot be read at all. Bad
// lines are reported with their numbers and skipped; a truncated log keeps what came before.
int mapLog(const Args& args, Feeder* feed, osm::tools::ProgressBar* bar, Intake* intake) {
  osm::CarmenLogReader reader(args.carmen);
  std::string error;
  if (!reader.open(args.log, &error)) {
    std::cerr << "octo_slice_map: " << error << "\n";
    return 1;
  }
  osm::LogScan record;
  while (reader.next(&record)) {
    feed->scan(record.scan, args.log + ":" + std::to_string(record.line));
    bar->update("mapping", reader.fileSize() ? double(reader.bytesRead()) / reader.fileSize() : 0.0);
  }
  bar->finish();
  intake->bad_lines = reader.problemCount();
  for (const osm::LogProblem& p : reader.problems()) {
    std::cerr << "octo_slice_map: " << args.log << ":" << p.line << ": " << p.message << " (line skipped)\n";
  }
  if (reader.problemCount() > reader.problems().size()) {
    std::cerr << "octo_slice_map: ... " << reader.problemCount() - reader.problems().size() << " more bad lines\n";
  }
  intake->end_error = reader.endError();
  if (!intake->end_error.empty()) {
    std::cerr << "octo_slice_map: " << intake->end_error << "; keeping the map built so far\n";
  }
  return 0;
}

// A bag's scans and clouds (through the bag's own tf) through `feed`; 0 or the exit status.
int mapBag(const Args& args, Feeder* feed, osm::tools::ProgressBar* bar, Intake* intake) {
  if (!args.hasScanTopic() && !args.hasCloudTopic()) {
    std::cerr << "octo_slice_map: --scan-topic \"\" needs a --cloud-topic\n";
    return 2;
  }
  osm::tools::BagHandlers handlers;
  std::size_t bag_scans = 0;
  handlers.scan = [&](const osm::Scan& scan) { feed->scan(scan, args.bag + ": scan " + std::to_string(bag_scans++)); };
  handlers.cloud = [&](const osm::DeferredCloud& cloud) {
    intake->clouds_read++;
    if (cloud.ground) intake->clouds_with_ground++;
    feed->cloud(cloud);
  };
  std::string error;
  if (!osm::tools::readBag(
          args.bag, {args.scan_topics, args.cloud_topics}, args.fixed_frame, handlers, &intake->skipped_scans, &error,
          [&](double f) { bar->update("mapping bag", f); }, args.floor_base_frame)) {
    std::cerr << "octo_slice_map: " << error << "\n";
    return 1;
  }
  bar->finish();
  const osm::ros_adapter::FloorBase base = osm::ros_adapter::floorBaseOf(args.floor_base_frame);
  const std::size_t without = intake->clouds_read - intake->clouds_with_ground;
  if (base.required && without > 0) {
    std::cerr << "octo_slice_map: " << without << " clouds mapped without a ground point (tf could not place "
              << base.frame << " at their stamps): their floor was found from their points alone\n";
  }
  return 0;
}

// What a service of the node would hold the map for: bringing the octree up to date with the
// insertion cache (here: everything, as nothing read the octree before), then the snapshot.
struct ReadCosts {
  double flush_ms = 0.0, snapshot_ms = 0.0;
  std::size_t snapshot_leaves = 0;
};
ReadCosts measureReadCosts(osm::Mapper* mapper) {
  ReadCosts costs;
  auto t0 = Clock::now();
  mapper->tree();
  costs.flush_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  t0 = Clock::now();
  costs.snapshot_leaves = mapper->snapshot(/*with_scans=*/true).tree->getNumLeafNodes();
  mapper->endSnapshot();
  costs.snapshot_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return costs;
}

std::string jsonReadings(const osm::ReadingCounts& counts) {
  std::ostringstream json;
  json << "{";
  for (int k = 0; k < osm::kReadingKindCount; ++k) {
    json << (k ? ", " : "") << '"' << osm::readingKindName(static_cast<osm::ReadingKind>(k)) << "\": " << counts.count[k];
  }
  json << "}";
  return json.str();
}

std::string jsonOptimizeReport(const osm::OptimizeReport& r, bool warm_start) {
  std::ostringstream json;
  json << "{\"start\": " << (warm_start ? "\"incremental\"" : "\"empty\"")
       << ", \"seconds\": " << r.build_seconds + r.optimize_seconds << ", \"index_seconds\": " << r.build_seconds
       << ", \"sweeps\": " << r.sweeps << ", \"converged\": " << (r.converged ? "true" : "false")
       << ", \"cells\": " << r.cells << ", \"beams\": " << r.beams << ", \"flips\": [";
  for (std::size_t k = 0; k < r.flips_per_sweep.size(); ++k) json << (k ? ", " : "") << r.flips_per_sweep[k];
  json << "], \"log_likelihood\": [" << r.initial_log_likelihood << ", " << r.final_log_likelihood
       << "], \"memory_mb\": " << r.memory_bytes / 1e6 << "}";
  return json.str();
}

// The one JSON line the tool prints.
std::string report(const Args& args, osm::Mapper& mapper, const Intake& intake, const ReadCosts& costs,
                   const osm::GridImage& incremental, const osm::SaveOutcome& saved) {
  const osm::MapperStats& stats = mapper.stats();
  const std::string source = args.log.empty() ? args.bag : args.log;
  std::ostringstream json;
  json << "{\"input\": " << jsonString(source) << ", \"scans\": " << stats.scans_inserted
       << ", \"held_out_scans\": " << intake.held_out.size() << ", \"beams\": " << intake.beams
       << ", \"readings\": " << jsonReadings(stats.readings)
       << ", \"beams_outside_octree\": " << stats.beams_outside_octree << ", \"skipped_scans\": {";
  bool first = true;
  for (const auto& kv : intake.skipped_scans) {
    json << (first ? "" : ", ") << jsonString(kv.first) << ": " << kv.second, first = false;
  }
  json << "}, \"bad_lines\": " << intake.bad_lines << ", \"log_error\": " << jsonString(intake.end_error)
       << ", \"resolution\": " << mapper.options().resolution << ", \"voxels\": " << mapper.tree().getNumLeafNodes()
       << ", \"known_cells\": " << mapper.slice().knownCells()
       << ", \"memory\": " << jsonMemory(mapper, intake.cloud_preparer_bytes) << ", \"insert_ms_per_scan\": "
       << (stats.scans_inserted ? 1000.0 * intake.insert_seconds / stats.scans_inserted : 0.0);
  if (args.hasCloudTopic()) {
    json << ", \"clouds\": " << stats.clouds_inserted << ", \"ms_per_cloud\": "
         << (stats.clouds_inserted ? 1000.0 * intake.cloud_seconds / stats.clouds_inserted : 0.0)
         << ", \"cloud_points\": " << jsonReadings(stats.cloud_points);
    json << ", \"clouds_with_ground\": " << intake.clouds_with_ground;
  }
  json << ", \"flush_ms\": " << costs.flush_ms << ", \"snapshot_ms\": " << costs.snapshot_ms
       << ", \"snapshot_leaves\": " << costs.snapshot_leaves
       << ", \"scan_store_mb\": " << mapper.scanStore().memoryBytes() / 1e6;
  static const osm::OptimizedMap kNone;
  const osm::OptimizedMap& optimized = saved.optimized ? *saved.optimized : kNone;
  if (saved.optimized) json << ", \"optimize\": " << jsonOptimizeReport(optimized.report, args.warm_start);
  if (!intake.held_out.empty()) {
    // As exported (the optimized map in the incremental map's frame, as saved).
    json << ", \"held_out\": {\"incremental\": "
         << jsonScore(osm::scoreHeldOut(osm::trinaryOf(incremental), intake.held_out));
    if (saved.optimized) {
      const osm::GridImage exported = osm::inFrameOf(optimized.grid, incremental);
      json << ", \"optimized\": " << jsonScore(osm::scoreHeldOut(osm::trinaryOf(exported), intake.held_out));
    }
    json << "}";
  }
  json << ", \"peak_rss_mb\": " << peakRssMb() << ", \"files\": [";
  for (std::size_t k = 0; k < saved.files.size(); ++k) json << (k ? ", " : "") << jsonString(saved.files[k]);
  json << "]}";
  return json.str();
}

}  // namespace

int main(int argc, char** argv) {
  Args parsed;
  int code = 0;
  if (!parse(argc, argv, &parsed, &code)) return code;
  const Args& args = parsed;
  osm::keepFreedMemoryForReuse();  // as the node: each frame's memory reused (memory_reuse.h)
  osm::tools::ProgressBar bar;
  std::unique_ptr<osm::MappingSession> session;
  osm::SessionOptions session_options;
  session_options.warm_start = args.warm_start;
  session_options.write_optimized_into_map = false;  // nothing reads the map after the pass
  try {
    session = std::make_unique<osm::MappingSession>(args.mapper, session_options);
  } catch (const std::exception& e) {
    std::cerr << "octo_slice_map: " << e.what() << "\n";
    return 2;
  }

  Intake intake;
  Feeder feed(args, session.get(), &intake);
  code = args.log.empty() ? mapBag(args, &feed, &bar, &intake) : mapLog(args, &feed, &bar, &intake);
  feed.finish();
  if (code != 0) return code;
  osm::Mapper& mapper = session->mapperUnlocked();  // no other thread here
  if (mapper.stats().scans_inserted == 0 && mapper.stats().clouds_inserted == 0) {
    std::cerr << "octo_slice_map: no scan could be inserted from " << (args.log.empty() ? args.bag : args.log) << "\n";
    return 1;
  }
  const ReadCosts costs = measureReadCosts(&mapper);

  const osm::GridImage incremental = osm::gridImageOf(mapper.slice());
  const osm::SaveOutcome saved =
      session->save(args.out, args.optimize, [&](const std::string& stage, double f) { bar.update(stage, f); });
  if (args.optimize) bar.finish();
  if (!saved.ok) {
    std::cerr << "octo_slice_map: " << saved.error << "\n";
    return 1;
  }
  if (!saved.note.empty()) std::cerr << "octo_slice_map: " << saved.note << "\n";
  std::cout << report(args, mapper, intake, costs, incremental, saved) << std::endl;
  return 0;
}
