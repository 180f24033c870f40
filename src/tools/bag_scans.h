// Scans from a rosbag, each placed with the bag's own tf (fixed frame <- laser at the scan's stamp).
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace tools {

struct BagScans {
  std::vector<Scan> scans;
  std::map<std::string, std::size_t> skipped;  // whole scans dropped, per reason
};

// False with a reason if the bag can't be read at all; bad or unplaceable scans are counted.
bool readBagScans(const std::string& path, const std::string& scan_topic, const std::string& fixed_frame,
                  BagScans* out, std::string* error, const std::function<void(double)>& progress = {});

}  // namespace tools
}  // namespace octo_slice_mapper
