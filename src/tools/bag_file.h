// Writing a rosbag whole or not at all, for the tools that make bags (carmen2bag, tum2bag).
#pragma once

#include <rosbag/bag.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <string>

namespace octo_slice_mapper {
namespace tools {

// `write(bag, error)` fills PATH.partial; when it returns true the file is closed and renamed to
// PATH. When it returns false (with its reason in `error`), throws, or the rename fails, the
// partial file is removed and PATH is left as it was. False with the reason in `error`.
inline bool writeBagWhole(const std::string& path, const std::function<bool(rosbag::Bag&, std::string*)>& write,
                          std::string* error) {
  const std::string partial = path + ".partial";
  try {
    rosbag::Bag bag(partial, rosbag::bagmode::Write);
    if (!write(bag, error)) {
      bag.close();
      std::remove(partial.c_str());
      return false;
    }
    bag.close();
  } catch (const std::exception& e) {
    std::remove(partial.c_str());
    *error = path + ": " + e.what();
    return false;
  }
  if (std::rename(partial.c_str(), path.c_str()) != 0) {
    *error = "cannot rename " + partial + ": " + std::strerror(errno);
    std::remove(partial.c_str());
    return false;
  }
  return true;
}

}  // namespace tools
}  // namespace octo_slice_mapper
