#include "octo_slice_mapper/carmen_log.h"

#include <sys/stat.h>
#include <zlib.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace octo_slice_mapper {

struct CarmenLogReader::GzFile {
  gzFile handle = nullptr;
  ~GzFile() {
    if (handle) gzclose(handle);
  }
};

namespace {

// Splits `line` in place at whitespace; the pointers stay valid while `line` is unchanged.
std::vector<const char*> tokenize(std::string* line) {
  std::vector<const char*> tokens;
  char* p = &(*line)[0];
  char* end = p + line->size();
  while (p < end) {
    while (p < end && std::isspace(static_cast<unsigned char>(*p))) *p++ = '\0';
    if (p < end) tokens.push_back(p);
    while (p < end && !std::isspace(static_cast<unsigned char>(*p))) ++p;
  }
  // The last token ends at line->size(), where std::string keeps a '\0'.
  return tokens;
}

bool toDouble(const char* token, double* value) {
  char* end = nullptr;
  errno = 0;
  *value = std::strtod(token, &end);
  return end != token && *end == '\0' && errno != ERANGE;
}

bool toCount(const char* token, std::size_t* value) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(token, &end, 10);
  if (end == token || *end != '\0' || errno == ERANGE || v < 0) return false;
  *value = static_cast<std::size_t>(v);
  return true;
}

Eigen::Isometry3d planarPose(double x, double y, double theta, double z) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(x, y, z);
  pose.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

}  // namespace

CarmenLogReader::CarmenLogReader(const CarmenLogOptions& options)
    : options_(options),
      front_max_range_(options.default_laser_max_range),
      rear_max_range_(options.default_laser_max_range) {}

CarmenLogReader::~CarmenLogReader() = default;

bool CarmenLogReader::open(const std::string& path, std::string* error) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
    *error = "cannot open log " + path + ": " + (errno ? std::strerror(errno) : "not a regular file");
    return false;
  }
  auto file = std::make_unique<GzFile>();
  file->handle = gzopen(path.c_str(), "rb");  // reads plain files transparently
  if (!file->handle) {
    *error = "cannot open log " + path + ": " + std::strerror(errno);
    return false;
  }
  gzbuffer(file->handle, 1 << 18);
  file_ = std::move(file);
  path_ = path;
  file_size_ = static_cast<std::uint64_t>(st.st_size);
  line_ = 0;
  problems_.clear();
  problem_count_ = 0;
  end_error_.clear();
  return true;
}

std::uint64_t CarmenLogReader::bytesRead() const {
  if (!file_) return 0;
  const z_off_t offset = gzoffset(file_->handle);
  return offset > 0 ? static_cast<std::uint64_t>(offset) : 0;
}

void CarmenLogReader::problem(const std::string& message) {
  ++problem_count_;
  if (problems_.size() < kMaxKeptProblems) problems_.push_back({line_, message});
}

// One whole line, however long (a 1081-beam ROBOTLASER1 line is ~10 kB).
bool CarmenLogReader::readLine(std::string* line) {
  line->clear();
  char chunk[1 << 16];
  while (gzgets(file_->handle, chunk, sizeof(chunk))) {
    line->append(chunk);
    if (!line->empty() && line->back() == '\n') break;
  }
  if (line->empty()) {
    int code = Z_OK;
    const char* message = gzerror(file_->handle, &code);
    if (code != Z_OK && code != Z_STREAM_END) {
      end_error_ = path_ + ": the log ends early after line " + std::to_string(line_) + " (" + message +
                   "): truncated or corrupt";
    }
    return false;
  }
  ++line_;
  return true;
}

void CarmenLogReader::parseParam(const std::vector<const char*>& tokens) {
  if (tokens.size() < 3) return;
  double value;
  if (!toDouble(tokens[2], &value) || !(value > 0.0)) return;
  if (std::strcmp(tokens[1], "robot_front_laser_max") == 0) front_max_range_ = value;
  if (std::strcmp(tokens[1], "robot_rear_laser_max") == 0) rear_max_range_ = value;
}

bool CarmenLogReader::parseRanges(const std::vector<const char*>& tokens, std::size_t first, std::size_t n,
                                  const std::string& kind, std::vector<float>* ranges) {
  ranges->resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    double r;
    if (!toDouble(tokens[first + i], &r)) {
      problem(kind + ": reading " + std::to_string(i) + " is not a number ('" + tokens[first + i] + "')");
      return false;
    }
    (*ranges)[i] = static_cast<float>(r);  // NaN/negative readings are classified by the mapper
  }
  return true;
}

bool CarmenLogReader::parsePose(const std::vector<const char*>& tokens, std::size_t first, const std::string& kind,
                                double pose[3]) {
  for (int k = 0; k < 3; ++k) {
    if (!toDouble(tokens[first + k], &pose[k]) || !std::isfinite(pose[k])) {
      problem(kind + ": laser pose is not a finite number");
      return false;
    }
  }
  return true;
}

bool CarmenLogReader::parseOldLaser(const std::vector<const char*>& tokens, const std::string& kind, LogScan* out) {
  std::size_t n = 0;
  if (tokens.size() < 2 || !toCount(tokens[1], &n) || n == 0 || n > options_.max_beams) {
    problem(kind + ": bad beam count");
    return false;
  }
  if (tokens.size() < 2 + n + 6) {
    problem(kind + ": " + std::to_string(n) + " beams announced, but the line has only " +
            std::to_string(tokens.size()) + " fields (needs ranges and two poses)");
    return false;
  }
  Scan& scan = out->scan;
  double pose[3];
  if (!parseRanges(tokens, 2, n, kind, &scan.ranges) || !parsePose(tokens, 2 + n, kind, pose)) return false;
  const double span = M_PI;
  const bool both_ends = n % 2 == 1;
  scan.angle_increment = static_cast<float>(span / static_cast<double>(both_ends ? n - 1 : n));
  if (n == 1) scan.angle_increment = static_cast<float>(span);
  scan.angle_min = static_cast<float>(-0.5 * M_PI);
  scan.range_min = 0.0f;
  scan.range_max = static_cast<float>(kind == "RLASER" ? rear_max_range_ : front_max_range_);
  scan.sensor_pose = planarPose(pose[0], pose[1], pose[2], options_.laser_z);
  double stamp = 0.0;
  scan.stamp = (tokens.size() >= 2 + n + 9 && toDouble(tokens.back(), &stamp)) ? stamp : 0.0;
  out->record = kind;
  return true;
}

bool CarmenLogReader::parseRobotLaser(const std::vector<const char*>& tokens, LogScan* out) {
  // ROBOTLASER1 type start fov resolution max_range accuracy remission_mode n ...
  double header[7];
  std::size_t n = 0, m = 0;
  if (tokens.size() < 9) {
    problem("ROBOTLASER1: too few fields");
    return false;
  }
  for (int k = 0; k < 7; ++k) {
    if (!toDouble(tokens[1 + k], &header[k]) || !std::isfinite(header[k])) {
      problem("ROBOTLASER1: bad header field " + std::to_string(k + 1));
      return false;
    }
  }
  if (!toCount(tokens[8], &n) || n == 0 || n > options_.max_beams || tokens.size() < 9 + n + 1) {
    problem("ROBOTLASER1: bad beam count or too few readings");
    return false;
  }
  if (!toCount(tokens[9 + n], &m) || m > options_.max_beams || tokens.size() < 10 + n + m + 6) {
    problem("ROBOTLASER1: bad remission count or missing poses");
    return false;
  }
  Scan& scan = out->scan;
  double pose[3];
  if (!parseRanges(tokens, 9, n, "ROBOTLASER1", &scan.ranges) || !parsePose(tokens, 10 + n + m, "ROBOTLASER1", pose)) {
    return false;
  }
  const double start = header[1], resolution = header[3], max_range = header[4];
  if (resolution == 0.0 || !(max_range > 0.0)) {
    problem("ROBOTLASER1: angular resolution must be non-zero and the maximum range positive");
    return false;
  }
  scan.angle_min = static_cast<float>(start);
  scan.angle_increment = static_cast<float>(resolution);
  scan.range_min = 0.0f;
  scan.range_max = static_cast<float>(max_range);
  scan.sensor_pose = planarPose(pose[0], pose[1], pose[2], options_.laser_z);
  double stamp = 0.0;
  scan.stamp = toDouble(tokens.back(), &stamp) ? stamp : 0.0;
  out->record = "ROBOTLASER1";
  return true;
}

bool CarmenLogReader::next(LogScan* out) {
  if (!file_) return false;
  while (readLine(&buffer_)) {
    const std::vector<const char*> tokens = tokenize(&buffer_);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const char* kind = tokens[0];
    bool ok = false;
    if (std::strcmp(kind, "FLASER") == 0 || std::strcmp(kind, "RLASER") == 0) {
      ok = parseOldLaser(tokens, kind, out);
    } else if (std::strcmp(kind, "ROBOTLASER1") == 0) {
      ok = parseRobotLaser(tokens, out);
    } else if (std::strcmp(kind, "PARAM") == 0) {
      parseParam(tokens);
    }
    if (ok) {
      out->line = line_;
      return true;
    }
  }
  return false;
}

std::vector<LogScan> readCarmenLog(const std::string& path, const CarmenLogOptions& options, std::string* error,
                                   std::vector<LogProblem>* problems, std::string* end_error) {
  std::vector<LogScan> scans;
  CarmenLogReader reader(options);
  if (!reader.open(path, error)) return scans;
  LogScan scan;
  while (reader.next(&scan)) scans.push_back(scan);
  if (problems) *problems = reader.problems();
  if (end_error) *end_error = reader.endError();
  return scans;
}

}  // namespace octo_slice_mapper
