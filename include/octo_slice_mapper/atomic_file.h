// Writing a file so that readers see either the old or the complete new content, never a torso.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace octo_slice_mapper {

// Writes `bytes` to a temporary file in the same folder, flushes it to disk and renames it over
// `path`. On any failure the temporary file is removed, `path` is untouched, and false is
// returned with the reason in `error`.
bool writeFileAtomically(const std::string& path, const std::string& bytes, std::string* error);

// Files to be written together: (path, bytes).
using FileSet = std::vector<std::pair<std::string, std::string>>;

// Writes every file to a temporary file beside it and flushes them all; only when all of them
// were written are they renamed into place, so a failure (a full disk, say) leaves every final
// name as it was and removes the temporary files. Appends the paths written to `written`.
bool writeFilesAtomically(const FileSet& files, std::vector<std::string>* written, std::string* error);

// Reads a whole file; false with a reason when it can't.
bool readFile(const std::string& path, std::string* bytes, std::string* error);

}  // namespace octo_slice_mapper
