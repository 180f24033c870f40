// octo_slice_map: offline mapping of a recorded log (CARMEN .log/.clf, gzip or plain) or rosbag.
//
//   octo_slice_map LOG [options]
//   octo_slice_map --bag FILE [--scan-topic scan] [--fixed-frame odom] [options]
//
// Writes PREFIX.{bt,ot,pgm,yaml,png} (and PREFIX_optimized.{bt,pgm,yaml,png} with --optimize) and
// prints a one-line JSON summary on stdout. Progress goes to stderr when it is a terminal.
#include <ros/package.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include "bag_scans.h"
#include "octo_slice_mapper/carmen_log.h"
#include "octo_slice_mapper/held_out_score.h"
#include "octo_slice_mapper/mapping_session.h"
#include "progress_bar.h"

namespace osm = octo_slice_mapper;
using Clock = std::chrono::steady_clock;

namespace {

const char kUsage[] = R"(usage: octo_slice_map LOG [options]
       octo_slice_map --bag FILE [--scan-topic scan] [--fixed-frame odom] [options]
input:  LOG is a CARMEN log (.log/.clf, plain or .gz): FLASER, RLASER, ROBOTLASER1 records
output: --out PREFIX            (default: the package's maps/<log name>)
map:    --resolution M (0.05)  --max-range M (0 = sensor's)  --slice-min-z M (0.16)  --slice-max-z M (0.36)
        --laser-z M (0.26, height given to 2D log scans)  --clamp-min P (0.003)  --clamp-max P (0.997)
model:  --beam-opening-angle RAD (0.0044)  --cone-covers-angle-step  --sigma-base M  --sigma-per-meter M
        --p-free P (0.4)  --p-occupied P (0.75)  --no-return-clear M (0)  --combine sum|occupied_wins
global: --optimize (from the incremental map)  --cold-start (from all-free, the lab's start)  --max-sweeps N (100)
        --z-hit W (0.83)  --z-rand W (0.15)  --z-miss W (0.02)  --forward-sigma-base M (0.01)
        --forward-sigma-per-meter M (0.005)
        --holdout-every N (keep every Nth scan from index 5 out of the maps; score both maps on
        them as exported: each held-out return cast through the .pgm's occupied cells)
)";

struct Args {
  std::string log, bag, scan_topic = "scan", fixed_frame = "odom", out;
  bool optimize = false, warm_start = true;  // warm: measured better on both shared logs (issue 18)
  int holdout_every = 0;
  osm::MapperOptions mapper;
  osm::CarmenLogOptions carmen;
};

double number(const std::string& flag, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v)) {
    std::cerr << "octo_slice_map: " << flag << " needs a number, got '" << text << "'\n";
    std::exit(2);
  }
  return v;
}

Args parse(int argc, char** argv) {
  Args a;
  // Nobody reads the octree until the end: one flush then writes each voxel once, instead of
  // rewriting the voxels that keep changing every 20 000 updates (Intel: 0.69 -> 0.56 ms/scan).
  a.mapper.max_unflushed_voxels = std::size_t{1} << 26;
  osm::InverseSensorModelOptions& m = a.mapper.insert.model;
  std::map<std::string, double*> numbers = {
      {"--resolution", &a.mapper.resolution},       {"--max-range", &a.mapper.insert.max_range},
      {"--slice-min-z", &a.mapper.slice.min_z},     {"--slice-max-z", &a.mapper.slice.max_z},
      {"--laser-z", &a.carmen.laser_z},             {"--clamp-min", &a.mapper.clamp_min},
      {"--clamp-max", &a.mapper.clamp_max},         {"--beam-opening-angle", &m.beam_opening_angle},
      {"--sigma-base", &m.sigma_base},              {"--sigma-per-meter", &m.sigma_per_meter},
      {"--p-free", &m.p_free},                      {"--p-occupied", &m.p_occupied},
      {"--no-return-clear", &m.no_return_clear_distance},
      {"--z-hit", &a.mapper.optimizer.model.z_hit},    {"--z-rand", &a.mapper.optimizer.model.z_rand},
      {"--z-miss", &a.mapper.optimizer.model.z_miss},  {"--forward-sigma-base", &a.mapper.optimizer.model.sigma_base},
      {"--forward-sigma-per-meter", &a.mapper.optimizer.model.sigma_per_meter}};
  std::map<std::string, std::string*> strings = {
      {"--bag", &a.bag}, {"--scan-topic", &a.scan_topic}, {"--fixed-frame", &a.fixed_frame}, {"--out", &a.out}};
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      std::exit(0);
    } else if (arg == "--optimize") {
      a.optimize = true;
    } else if (arg == "--cone-covers-angle-step") {
      m.cone_covers_angle_step = true;
    } else if (arg == "--combine" && has_value) {
      const std::string how = argv[++i];
      if (how != "sum" && how != "occupied_wins") {
        std::cerr << "octo_slice_map: --combine takes sum or occupied_wins, got '" << how << "'\n";
        std::exit(2);
      }
      a.mapper.insert.combining = how == "sum" ? osm::EvidenceCombining::kSum : osm::EvidenceCombining::kOccupiedWins;
    } else if (arg == "--warm-start") {  // the default start; kept for scripts that name it
      a.optimize = a.warm_start = true;
    } else if (arg == "--cold-start") {
      a.optimize = true;
      a.warm_start = false;
    } else if (arg == "--max-sweeps" && has_value) {
      a.mapper.optimizer.max_sweeps = static_cast<int>(number(arg, argv[++i]));
    } else if (arg == "--holdout-every" && has_value) {
      a.holdout_every = static_cast<int>(number(arg, argv[++i]));
    } else if (numbers.count(arg) && has_value) {
      *numbers[arg] = number(arg, argv[++i]);
    } else if (strings.count(arg) && has_value) {
      *strings[arg] = argv[++i];
    } else if (arg[0] != '-' && a.log.empty()) {
      a.log = arg;
    } else {
      std::cerr << "octo_slice_map: unknown or incomplete option '" << arg << "'\n" << kUsage;
      std::exit(2);
    }
  }
  if (a.log.empty() == a.bag.empty()) {
    std::cerr << "octo_slice_map: give either a CARMEN log or --bag FILE\n" << kUsage;
    std::exit(2);
  }
  if (a.out.empty()) {
    std::string stem = a.log.empty() ? a.bag : a.log;
    stem = stem.substr(stem.find_last_of('/') + 1);
    for (const char* ext : {".gz", ".log", ".clf", ".bag"}) {
      const std::string e = ext;
      if (stem.size() > e.size() && stem.compare(stem.size() - e.size(), e.size(), e) == 0) stem.resize(stem.size() - e.size());
    }
    const std::string package = ros::package::getPath("octo_slice_mapper");
    a.out = package.empty() ? stem : package + "/maps/" + stem;
  }
  return a;
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
std::string jsonMemory(osm::Mapper& mapper) {
  const double cells = std::max<std::size_t>(1, mapper.slice().knownCells());
  const std::size_t octree = mapper.tree().memoryUsage();
  const std::size_t slice = mapper.slice().memoryBytes();
  const std::size_t cache = mapper.inserter().memoryBytes();
  std::ostringstream j;
  j << "{\"octree_bytes\": " << octree << ", \"slice_bytes\": " << slice << ", \"insertion_cache_bytes\": " << cache
    << ", \"octree_bytes_per_cell\": " << octree / cells << ", \"slice_bytes_per_cell\": " << slice / cells
    << ", \"insertion_cache_bytes_per_cell\": " << cache / cells << "}";
  return j.str();
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
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

  std::vector<osm::Scan> held_out;
  std::size_t scans_read = 0, beams = 0;
  double insert_seconds = 0.0;
  std::map<std::string, std::size_t> skipped_scans;
  std::size_t refused_reported = 0;
  // `where`: the log and line (or bag message) the scan came from, for the report of a refused one.
  auto consume = [&](const osm::Scan& scan, const std::string& where) {
    const bool hold = osm::HoldOut{args.holdout_every, 5}.holds(scans_read);
    ++scans_read;
    if (hold) {
      held_out.push_back(scan);
      return;
    }
    const auto t0 = Clock::now();
    const osm::InsertResult result = session->insert(scan);
    insert_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    if (!result.ok()) {
      skipped_scans["invalid_scan"]++;
      if (++refused_reported <= 20) std::cerr << "octo_slice_map: " << where << ": scan skipped: " << result.error << "\n";
      if (refused_reported == 21) std::cerr << "octo_slice_map: (further skipped scans are only counted)\n";
      return;
    }
    beams += scan.ranges.size();
  };

  std::string error, end_error, source = args.log.empty() ? args.bag : args.log;
  std::size_t bad_lines = 0;
  if (!args.log.empty()) {
    osm::CarmenLogReader reader(args.carmen);
    if (!reader.open(args.log, &error)) {
      std::cerr << "octo_slice_map: " << error << "\n";
      return 1;
    }
    osm::LogScan record;
    while (reader.next(&record)) {
      consume(record.scan, args.log + ":" + std::to_string(record.line));
      bar.update("mapping", reader.fileSize() ? double(reader.bytesRead()) / reader.fileSize() : 0.0);
    }
    bar.finish();
    bad_lines = reader.problemCount();
    for (const osm::LogProblem& p : reader.problems()) {
      std::cerr << "octo_slice_map: " << args.log << ":" << p.line << ": " << p.message << " (line skipped)\n";
    }
    if (reader.problemCount() > reader.problems().size()) {
      std::cerr << "octo_slice_map: ... " << reader.problemCount() - reader.problems().size() << " more bad lines\n";
    }
    end_error = reader.endError();
    if (!end_error.empty()) std::cerr << "octo_slice_map: " << end_error << "; keeping the map built so far\n";
  } else {
    osm::tools::BagScans bag;
    if (!osm::tools::readBagScans(args.bag, args.scan_topic, args.fixed_frame, &bag, &error,
                                  [&](double f) { bar.update("reading bag", f); })) {
      std::cerr << "octo_slice_map: " << error << "\n";
      return 1;
    }
    skipped_scans = bag.skipped;
    for (std::size_t k = 0; k < bag.scans.size(); ++k) {
      consume(bag.scans[k], args.bag + ": scan " + std::to_string(k));
      bar.update("mapping", double(k + 1) / bag.scans.size());
    }
    bar.finish();
  }
  osm::Mapper& mapper = session->mapperUnlocked();  // no other thread here
  if (mapper.stats().scans_inserted == 0) {
    std::cerr << "octo_slice_map: no scan could be inserted from " << source << "\n";
    return 1;
  }

  // What a service of the node would hold the map for: bringing the octree up to date with the
  // insertion cache (here: everything, as nothing read the octree before), then the snapshot.
  auto t0 = Clock::now();
  mapper.tree();
  const double flush_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  t0 = Clock::now();
  const std::size_t snapshot_leaves = mapper.snapshot(/*with_scans=*/true).tree->getNumLeafNodes();
  mapper.endSnapshot();
  const double snapshot_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

  const osm::GridImage incremental = osm::gridImageOf(mapper.slice());
  const osm::SaveOutcome saved =
      session->save(args.out, args.optimize, [&](const std::string& stage, double f) { bar.update(stage, f); });
  if (args.optimize) bar.finish();
  if (!saved.ok) {
    std::cerr << "octo_slice_map: " << saved.error << "\n";
    return 1;
  }
  if (!saved.note.empty()) std::cerr << "octo_slice_map: " << saved.note << "\n";
  const std::vector<std::string>& files = saved.files;
  const osm::OptimizedMap optimized = saved.optimized.value_or(osm::OptimizedMap());

  const osm::MapperStats& stats = mapper.stats();
  std::ostringstream json;
  json << "{\"input\": " << jsonString(source) << ", \"scans\": " << stats.scans_inserted
       << ", \"held_out_scans\": " << held_out.size() << ", \"beams\": " << beams << ", \"readings\": {";
  for (int k = 0; k < osm::kReadingKindCount; ++k) {
    json << (k ? ", " : "") << '"' << osm::readingKindName(static_cast<osm::ReadingKind>(k))
         << "\": " << stats.readings.count[k];
  }
  json << "}, \"skipped_scans\": {";
  bool first = true;
  for (const auto& kv : skipped_scans) json << (first ? "" : ", ") << jsonString(kv.first) << ": " << kv.second, first = false;
  json << "}, \"bad_lines\": " << bad_lines << ", \"log_error\": " << jsonString(end_error)
       << ", \"resolution\": " << mapper.options().resolution << ", \"voxels\": " << mapper.tree().getNumLeafNodes()
       << ", \"known_cells\": " << mapper.slice().knownCells()
       << ", \"memory\": " << jsonMemory(mapper)
       << ", \"insert_ms_per_scan\": " << 1000.0 * insert_seconds / stats.scans_inserted
       << ", \"flush_ms\": " << flush_ms << ", \"snapshot_ms\": " << snapshot_ms
       << ", \"snapshot_leaves\": " << snapshot_leaves
       << ", \"scan_store_mb\": " << mapper.scanStore().memoryBytes() / 1e6;
  if (args.optimize) {
    const osm::OptimizeReport& r = optimized.report;
    json << ", \"optimize\": {\"start\": " << (args.warm_start ? "\"incremental\"" : "\"empty\"")
         << ", \"seconds\": " << r.build_seconds + r.optimize_seconds << ", \"index_seconds\": " << r.build_seconds
         << ", \"sweeps\": " << r.sweeps << ", \"converged\": " << (r.converged ? "true" : "false")
         << ", \"cells\": " << r.cells << ", \"beams\": " << r.beams << ", \"flips\": [";
    for (std::size_t k = 0; k < r.flips_per_sweep.size(); ++k) json << (k ? ", " : "") << r.flips_per_sweep[k];
    json << "], \"log_likelihood\": [" << r.initial_log_likelihood << ", " << r.final_log_likelihood
         << "], \"memory_mb\": " << r.memory_bytes / 1e6 << "}";
  }
  if (!held_out.empty()) {
    // As exported (the optimized map in the incremental map's frame, as saved).
    json << ", \"held_out\": {\"incremental\": " << jsonScore(osm::scoreHeldOut(osm::trinaryOf(incremental), held_out));
    if (args.optimize) {
      const osm::GridImage saved = osm::inFrameOf(optimized.grid, incremental);
      json << ", \"optimized\": " << jsonScore(osm::scoreHeldOut(osm::trinaryOf(saved), held_out));
    }
    json << "}";
  }
  json << ", \"peak_rss_mb\": " << peakRssMb() << ", \"files\": [";
  for (std::size_t k = 0; k < files.size(); ++k) json << (k ? ", " : "") << jsonString(files[k]);
  json << "]}";
  std::cout << json.str() << std::endl;
  return 0;
}
