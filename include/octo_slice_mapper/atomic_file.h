// Writing a file so that readers see either the old or the complete new content, never a torso.
#pragma once

#include <string>

namespace octo_slice_mapper {

// Writes `bytes` to a temporary file in the same folder, flushes it to disk and renames it over
// `path`. On any failure the temporary file is removed, `path` is untouched, and false is
// returned with the reason in `error`.
bool writeFileAtomically(const std::string& path, const std::string& bytes, std::string* error);

// Reads a whole file; false with a reason when it can't.
bool readFile(const std::string& path, std::string* bytes, std::string* error);

}  // namespace octo_slice_mapper
