// Reading laser scans with their (corrected) poses from CARMEN logs, plain or gzip.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {

// Record kinds read (the Radish / Freiburg logs):
//   FLASER / RLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//     Old format without angle fields: the beams span 180 deg from -90 deg; n even means
//     n steps of 180/n deg (180 -> 1 deg, 360 -> 0.5 deg), n odd includes both ends
//     (181 -> 1 deg, 361 -> 0.5 deg, -90..+90). x y theta is the laser's pose.
//   ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
//     m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fwd side turn
//     ipc_timestamp host logger_timestamp
// Other records (ODOM, PARAM, NEFF, comments, ...) are skipped silently, except the PARAMs
// robot_front_laser_max / robot_rear_laser_max, which set the range of FLASER / RLASER.
struct CarmenLogOptions {
  // Laser height above the floor (m): CARMEN logs are 2D; the scan is placed at this z so that
  // the slice's z band finds it. Default: the lab's TurtleBot mount.
  double laser_z = 0.26;
  // FLASER/RLASER range limit when the log has no robot_*_laser_max PARAM. SICK LMS scanners
  // report "no return" as ~81.83 m, above this.
  double default_laser_max_range = 80.0;
  // Beams per record above this are refused as a bad line.
  std::size_t max_beams = 100000;
};

struct LogScan {
  Scan scan;                 // sensor_pose = laser pose in the log's (corrected) frame
  std::size_t line = 0;      // 1-based line number in the log
  std::string record;        // FLASER, RLASER or ROBOTLASER1
};

// A bad line: where and why. The reader skips it and carries on.
struct LogProblem {
  std::size_t line;
  std::string message;
};

class CarmenLogReader {
 public:
  explicit CarmenLogReader(const CarmenLogOptions& options = {});
  ~CarmenLogReader();
  CarmenLogReader(const CarmenLogReader&) = delete;
  CarmenLogReader& operator=(const CarmenLogReader&) = delete;

  // Opens a log (gzip or plain, detected by content). False with a reason if it can't be read.
  bool open(const std::string& path, std::string* error);
  // The next laser record; false at the end of the log (or when it ends early: see endError()).
  bool next(LogScan* out);

  // Bad lines met so far (the first kMaxKeptProblems are kept; problemCount() counts all).
  const std::vector<LogProblem>& problems() const { return problems_; }
  std::size_t problemCount() const { return problem_count_; }
  static constexpr std::size_t kMaxKeptProblems = 100;
  // Non-empty when the log ended early (a truncated or corrupt gzip): what went wrong and where.
  const std::string& endError() const { return end_error_; }
  std::size_t linesRead() const { return line_; }
  // Compressed bytes consumed and the file's size, for progress bars.
  std::uint64_t bytesRead() const;
  std::uint64_t fileSize() const { return file_size_; }

 private:
  bool readLine(std::string* line);
  void problem(const std::string& message);
  // n readings from tokens[first], and the pose triple at tokens[first]; false (reported) if bad.
  bool parseRanges(const std::vector<const char*>& tokens, std::size_t first, std::size_t n, const std::string& kind,
                   std::vector<float>* ranges);
  bool parsePose(const std::vector<const char*>& tokens, std::size_t first, const std::string& kind, double pose[3]);
  bool parseOldLaser(const std::vector<const char*>& tokens, const std::string& kind, LogScan* out);
  bool parseRobotLaser(const std::vector<const char*>& tokens, LogScan* out);
  void parseParam(const std::vector<const char*>& tokens);

  CarmenLogOptions options_;
  struct GzFile;
  std::unique_ptr<GzFile> file_;
  std::string path_;
  std::uint64_t file_size_ = 0;
  std::size_t line_ = 0;
  std::vector<LogProblem> problems_;
  std::size_t problem_count_ = 0;
  std::string end_error_;
  double front_max_range_, rear_max_range_;
  std::string buffer_;
};

// Reads all laser records of a log. `problems` and `end_error` may be null.
std::vector<LogScan> readCarmenLog(const std::string& path, const CarmenLogOptions& options, std::string* error,
                                   std::vector<LogProblem>* problems = nullptr, std::string* end_error = nullptr);

}  // namespace octo_slice_mapper
