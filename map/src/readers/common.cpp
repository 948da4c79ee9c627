// SPDX-License-Identifier: BSD-3-Clause
#include "common.hpp"

#include <open3d/utility/Logging.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>

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

std::string& open3dLastError() {
  static std::string last;
  return last;
}

void quietOpen3d() {
  static std::once_flag once;
  std::call_once(once, [] {
    auto& logger = open3d::utility::Logger::GetInstance();
    logger.SetPrintFunction([](const std::string& msg) { open3dLastError() = msg; });
    logger.SetVerbosityLevel(open3d::utility::VerbosityLevel::Warning);
  });
  open3dLastError().clear();
}

std::string extensionOf(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

}  // namespace adit::map::readers_internal
