// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Private helpers of the readers: bytes handed to a library that only opens files (Open3D), and
// little-endian field access that never reads past the buffer.
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "adit/map/readers/geometry.hpp"
#include "readers/open3d_module.hpp"

namespace adit::map::readers_internal {

/// An anonymous in-memory file holding `bytes`, reachable by path (/proc/self/fd/N) for
/// libraries that only read files. Closed on destruction; nothing touches the disk.
class MemFile {
 public:
  static StatusOr<MemFile> create(const std::string& bytes, const std::string& name);
  MemFile(MemFile&& o) noexcept : fd_(o.fd_), path_(std::move(o.path_)) { o.fd_ = -1; }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;
  MemFile& operator=(MemFile&&) = delete;
  ~MemFile();
  const std::string& path() const { return path_; }

 private:
  MemFile(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::string path_;
};

/// The Open3D module (readers/open3d_module.hpp), loaded on the first call: from ADIT_OPEN3D_MODULE
/// when set, else beside the program as installed (../lib/adit from its bin folder), else where
/// this build put it. An error says where it looked and why each failed.
StatusOr<const Open3dModule*> open3dModule();
/// The points of the cloud file `path` in `format` ("pcd", "ply"), decoded by the Open3D module,
/// which must give exactly `expected` of them. Errors name `name`: "cannot decode " + `what`
/// (with Open3D's message), or "decoded N " + `noun` + ", header says M".
StatusOr<std::vector<Vec3>> decodeCloud(const std::string& path, const char* format, const std::string& name,
                                        const std::string& what, std::uint64_t expected, const char* noun);
/// Open3D's message for a failed decode, as " (message)", or "".
std::string open3dWhy(const std::string& error);

template <class T>
T loadLE(const std::string& b, std::size_t off) {
  T v;
  std::memcpy(&v, b.data() + off, sizeof(T));
  return v;
}

/// Lowercased extension with the dot (".pcd"), or "".
std::string extensionOf(const std::string& path);

}  // namespace adit::map::readers_internal
