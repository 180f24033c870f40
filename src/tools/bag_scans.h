// Scans and clouds from a rosbag, each placed with the bag's own tf (fixed frame <- sensor at the
// message's stamp), handed on one at a time in the bag's order (a depth camera's bag is gigabytes:
// nothing is kept).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace tools {

// The topics read: scans from every topic of `scans`, clouds from every topic of `clouds`, all in
// the bag's order (each message placed with its own frame); an empty name stands for none.
struct BagTopics {
  std::vector<std::string> scans;   // sensor_msgs/LaserScan
  std::vector<std::string> clouds;  // sensor_msgs/PointCloud2
};

struct BagHandlers {
  std::function<void(const Scan&)> scan;
  std::function<void(const DeferredCloud&)> cloud;  // its points made when asked (on a pipeline's worker)
};

// False with a reason if the bag can't be read at all or holds nothing on the topics; messages
// that are bad or cannot be placed are counted in `skipped` per reason (clouds' reasons start
// with "cloud_"). `floor_base_frame` names the tf frame whose origin is each cloud's ground point
// (SensorCloud::ground), as the node's parameter does ("auto": base_footprint where tf has it; "":
// none); a cloud tf cannot place it for is handed on without one (and is not counted as skipped:
// it is mapped, its floor found from its points alone).
bool readBag(const std::string& path, const BagTopics& topics, const std::string& fixed_frame,
             const BagHandlers& handlers, std::map<std::string, std::size_t>* skipped, std::string* error,
             const std::function<void(double)>& progress = {}, const std::string& floor_base_frame = "");

struct BagScans {
  std::vector<Scan> scans;
  std::map<std::string, std::size_t> skipped;  // whole scans dropped, per reason
};

// The scans of one topic, kept (for the tests and small bags).
bool readBagScans(const std::string& path, const std::string& scan_topic, const std::string& fixed_frame,
                  BagScans* out, std::string* error, const std::function<void(double)>& progress = {});

}  // namespace tools
}  // namespace octo_slice_mapper
