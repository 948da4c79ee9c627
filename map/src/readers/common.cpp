// SPDX-License-Identifier: BSD-3-Clause
#include "common.hpp"

#include <dlfcn.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <cstdlib>
#include <mutex>
#include <vector>

namespace adit::map::readers_internal {

std::string at(const std::string& name, std::uint64_t offset) {
  return name + ": offset " + std::to_string(offset);
}
std::string atLine(const std::string& name, std::uint64_t line) { return name + ":" + std::to_string(line); }

std::int64_t firstNonFinite(const std::vector<Vec3>& pts) {
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (!pts[i].allFinite()) return std::int64_t(i);
  return -1;
}

StatusOr<MemFile> MemFile::create(const std::string& bytes, const std::string& name) {
  const int fd = memfd_create("adit-import", MFD_CLOEXEC);
  if (fd < 0) return internalError(name + ": cannot create an in-memory file for the reader");
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (w <= 0) {
      ::close(fd);
      return internalError(name + ": cannot fill the in-memory file for the reader");
    }
    done += std::size_t(w);
  }
  return MemFile(fd, "/proc/self/fd/" + std::to_string(fd));
}

MemFile::~MemFile() {
  if (fd_ >= 0) ::close(fd_);
}

StatusOr<const Open3dModule*> open3dModule() {
  static std::once_flag once;
  static const Open3dModule* module = nullptr;
  static std::string why;
  std::call_once(once, [] {
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("ADIT_OPEN3D_MODULE"); env && *env) candidates.push_back(env);
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back((exe.parent_path() / ADIT_OPEN3D_MODULE_FROM_BIN).lexically_normal().string());
    candidates.push_back(ADIT_OPEN3D_MODULE_INSTALLED);
    candidates.push_back(ADIT_OPEN3D_MODULE_BUILT);
    auto failed = [](const std::string& path, const std::string& reason) {
      why += (why.empty() ? "" : "; ") + path + ": " + reason;
    };
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const std::string& path = candidates[i];
      if (std::find(candidates.begin(), candidates.begin() + std::ptrdiff_t(i), path) != candidates.begin() + std::ptrdiff_t(i))
        continue;  // the build's own place, reached twice
      if (!std::filesystem::exists(path, ec)) {
        failed(path, "not there");
        continue;
      }
      // Never closed: the decoders stay loaded for the process.
      void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        const char* e = ::dlerror();
        failed(path, e ? e : "cannot load");
        continue;
      }
      using Entry = const Open3dModule* (*)();
      const auto entry = reinterpret_cast<Entry>(::dlsym(handle, kOpen3dModuleEntry));
      const Open3dModule* m = entry ? entry() : nullptr;
      if (!m || m->version != kOpen3dModuleVersion || !m->read_cloud || !m->read_png) {
        failed(path, "not this build's module");
        continue;
      }
      module = m;
      return;
    }
  });
  if (module) return module;
  return failedPrecondition("decoding PCD, PLY and PNG needs adit's Open3D module, which did not load (" + why +
                            "); set ADIT_OPEN3D_MODULE to its path");
}

std::string open3dWhy(const std::string& error) {
  // Open3D colours its messages for a terminal ("\x1b[1;33m[Open3D WARNING] ...\x1b[0;m"): our
  // report is plain text, perhaps in a log or JSON.
  std::string plain;
  for (std::size_t i = 0; i < error.size(); ++i) {
    if (error[i] == '\x1b' && i + 1 < error.size() && error[i + 1] == '[') {
      const std::size_t m = error.find('m', i);
      if (m == std::string::npos) break;
      i = m;
      continue;
    }
    plain.push_back(error[i]);
  }
  while (!plain.empty() && std::isspace(static_cast<unsigned char>(plain.back()))) plain.pop_back();
  return plain.empty() ? std::string() : " (" + plain + ")";
}

StatusOr<std::vector<Vec3>> decodeCloud(const std::string& path, const char* format, const std::string& name,
                                        const std::string& what, std::uint64_t expected, const char* noun) {
  ADIT_ASSIGN_OR_RETURN(const Open3dModule* o3d, open3dModule());
  std::vector<double> xyz;
  std::string why;
  if (!o3d->read_cloud(path.c_str(), format, &xyz, &why))
    return dataLoss(name + ": cannot decode " + what + open3dWhy(why));
  if (xyz.size() / 3 != expected)
    return dataLoss(name + ": decoded " + std::to_string(xyz.size() / 3) + " " + noun + ", header says " +
                    std::to_string(expected));
  std::vector<Vec3> pts(xyz.size() / 3);
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i] = Vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return pts;
}

std::string extensionOf(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

}  // namespace adit::map::readers_internal
