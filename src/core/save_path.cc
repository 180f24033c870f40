#include "core/internal/save_path.h"

#include <climits>
#include <cstdlib>

namespace octo_slice_mapper {
namespace {

bool canonical(const std::string& path, std::string* out) {
  char buffer[PATH_MAX];
  if (!::realpath(path.c_str(), buffer)) return false;
  *out = buffer;
  return true;
}

}  // namespace

bool resolveSavePrefix(const std::string& maps_dir, const std::string& requested, bool allow_any_path,
                       std::string* resolved, std::string* error) {
  if (requested.empty()) {
    *error = "empty path prefix";
    return false;
  }
  for (unsigned char c : requested) {
    // A newline would end up in the .yaml's image line, which no YAML reader then parses.
    if (c < 0x20 || c == 0x7F) {
      *error = "refused: the prefix holds a control character (code " + std::to_string(int(c)) + ")";
      return false;
    }
  }
  const std::string candidate = requested[0] == '/' ? requested : maps_dir + "/" + requested;
  const auto slash = candidate.find_last_of('/');
  const std::string folder = candidate.substr(0, slash == 0 ? 1 : slash);
  const std::string name = candidate.substr(slash + 1);
  if (name.empty() || name == "." || name == "..") {
    *error = "'" + requested + "' does not end in a file name prefix";
    return false;
  }
  // The longest file of a set is NAME.yaml; a longer name would fail half-way through a save.
  // The longest name a save writes is PREFIX_incremental.yaml (map_io.h's saveMapSet).
  constexpr std::size_t kLongestExtension = sizeof("_incremental.yaml") - 1;
  if (name.size() + kLongestExtension > NAME_MAX) {
    *error = "refused: the file name prefix has " + std::to_string(name.size()) + " characters; with \"_incremental.yaml\" it " +
             "must fit in " + std::to_string(NAME_MAX) + " (at most " + std::to_string(NAME_MAX - kLongestExtension) + ")";
    return false;
  }
  std::string real_folder;
  if (!canonical(folder, &real_folder)) {
    *error = "folder of '" + requested + "' does not exist (" + folder + ")";
    return false;
  }
  if (!allow_any_path) {
    std::string real_maps;
    if (!canonical(maps_dir, &real_maps)) {
      *error = "maps_dir '" + maps_dir + "' does not exist";
      return false;
    }
    const bool inside = real_folder == real_maps ||
                        (real_folder.size() > real_maps.size() && real_folder.compare(0, real_maps.size(), real_maps) == 0 &&
                         real_folder[real_maps.size()] == '/');
    if (!inside) {
      *error = "refused: '" + requested + "' resolves to " + real_folder + ", outside maps_dir " + real_maps +
               " (set ~allow_any_path to write elsewhere)";
      return false;
    }
  }
  *resolved = (real_folder == "/" ? "" : real_folder) + "/" + name;
  return true;
}

}  // namespace octo_slice_mapper
