// Where a save request may write: inside the maps folder unless explicitly allowed elsewhere.
#pragma once

#include <string>

namespace octo_slice_mapper {

// Resolves a requested path prefix (relative ones are taken inside `maps_dir`). Unless
// `allow_any_path`, the prefix's folder must resolve (after following symlinks and "..") to
// `maps_dir` or a folder below it. The folder must exist. On success `resolved` holds the prefix
// with its folder made canonical.
bool resolveSavePrefix(const std::string& maps_dir, const std::string& requested, bool allow_any_path,
                       std::string* resolved, std::string* error);

}  // namespace octo_slice_mapper
