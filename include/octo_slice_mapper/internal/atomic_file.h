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
// name as it was and removes the temporary files. Temporary files of these paths that a killed
// save left are removed first. Appends the paths written to `written`.
bool writeFilesAtomically(const FileSet& files, std::vector<std::string>* written, std::string* error);

// Temporary files these writers leave when a process is killed mid-save: PATH.tmp-XXXXXX (six
// characters from mkstemp). Removes those of `path` (before a save writes it again), or all of a
// folder's (at start-up); returns how many were removed. Only one process should save into a
// folder at a time: another's temporary file, removed under it, fails its save with a reason.
std::size_t removeStaleTemporaries(const std::string& path);
std::size_t removeStaleTemporariesIn(const std::string& folder);

// Reads a whole file; false with a reason when it can't.
bool readFile(const std::string& path, std::string* bytes, std::string* error);

}  // namespace octo_slice_mapper
