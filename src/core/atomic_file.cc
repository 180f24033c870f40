#include "octo_slice_mapper/internal/atomic_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

namespace octo_slice_mapper {

namespace {

constexpr char kTempTag[] = ".tmp-";
constexpr std::size_t kTempSuffix = sizeof(kTempTag) - 1 + 6;  // ".tmp-" and mkstemp's six characters

// The part of a file name its temporary files start with: all of it unless that would make the
// temporary's name longer than a name can be (a 250-character final name is allowed).
std::string temporaryStem(const std::string& name) { return name.substr(0, NAME_MAX - kTempSuffix); }

// `path` as (folder, file name); the folder is "" for a bare name.
std::pair<std::string, std::string> splitPath(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return {"", path};
  return {path.substr(0, slash == 0 ? 1 : slash), path.substr(slash + 1)};
}

// Removes the entries of `folder` named `stem` + ".tmp-XXXXXX" (any stem when `stem` is null).
std::size_t removeTemporaries(const std::string& folder, const std::string* stem) {
  DIR* dir = ::opendir(folder.empty() ? "." : folder.c_str());
  if (!dir) return 0;
  std::vector<std::string> stale;
  while (const dirent* entry = ::readdir(dir)) {
    const std::string name = entry->d_name;
    if (name.size() <= kTempSuffix) continue;
    const std::size_t tag = name.size() - kTempSuffix;
    if (name.compare(tag, sizeof(kTempTag) - 1, kTempTag) != 0) continue;
    if (stem && name.compare(0, tag, *stem) != 0) continue;
    if (stem && tag != stem->size()) continue;
    stale.push_back((folder.empty() ? "" : folder + "/") + name);
  }
  ::closedir(dir);
  std::size_t removed = 0;
  for (const std::string& path : stale) removed += ::unlink(path.c_str()) == 0;
  return removed;
}

// Writes `bytes` to a new temporary file beside `path` and flushes it; its name goes to `temp`.
bool writeTemporary(const std::string& path, const std::string& bytes, std::string* temp, std::string* error) {
  const auto [folder, name_of_path] = splitPath(path);
  const std::string dir = folder.empty() ? "" : folder == "/" ? "/" : folder + "/";
  std::string tmpl = dir + temporaryStem(name_of_path) + kTempTag + "XXXXXX";
  std::vector<char> name(tmpl.begin(), tmpl.end());
  name.push_back('\0');
  const int fd = ::mkstemp(name.data());
  if (fd < 0) {
    *error = "cannot create a temporary file beside " + path + ": " + std::strerror(errno);
    return false;
  }
  auto fail = [&](const std::string& what) {
    *error = what + " " + path + ": " + std::strerror(errno);
    ::close(fd);
    ::unlink(name.data());
    return false;
  };
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail("cannot write");
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fchmod(fd, 0644) != 0) return fail("cannot set permissions of");
  if (::fsync(fd) != 0) return fail("cannot flush");
  if (::close(fd) != 0) {
    *error = "cannot close temporary file for " + path + ": " + std::strerror(errno);
    ::unlink(name.data());
    return false;
  }
  *temp = name.data();
  return true;
}

}  // namespace

bool writeFilesAtomically(const FileSet& files, std::vector<std::string>* written, std::string* error) {
  // What a save killed earlier left of these files goes first.
  for (const auto& file : files) removeStaleTemporaries(file.first);
  std::vector<std::string> temps;
  for (const auto& file : files) {
    std::string temp;
    if (!writeTemporary(file.first, file.second, &temp, error)) {
      for (const std::string& t : temps) ::unlink(t.c_str());
      return false;
    }
    temps.push_back(temp);
  }
  for (std::size_t k = 0; k < files.size(); ++k) {
    if (::rename(temps[k].c_str(), files[k].first.c_str()) != 0) {
      *error = "cannot rename temporary file onto " + files[k].first + ": " + std::strerror(errno);
      for (std::size_t j = k; j < temps.size(); ++j) ::unlink(temps[j].c_str());
      return false;
    }
    if (written) written->push_back(files[k].first);
  }
  return true;
}

bool writeFileAtomically(const std::string& path, const std::string& bytes, std::string* error) {
  return writeFilesAtomically({{path, bytes}}, nullptr, error);
}

bool readFile(const std::string& path, std::string* bytes, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot open " + path + ": " + std::strerror(errno);
    return false;
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) {
    *error = "cannot read " + path;
    return false;
  }
  *bytes = buffer.str();
  return true;
}

std::size_t removeStaleTemporaries(const std::string& path) {
  const auto [folder, name] = splitPath(path);
  const std::string stem = temporaryStem(name);
  return removeTemporaries(folder, &stem);
}

std::size_t removeStaleTemporariesIn(const std::string& folder) { return removeTemporaries(folder, nullptr); }

}  // namespace octo_slice_mapper
