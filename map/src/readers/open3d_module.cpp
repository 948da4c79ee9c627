// SPDX-License-Identifier: BSD-3-Clause
// The Open3D module (see open3d_module.hpp): built as a MODULE library, loaded with dlopen.
#include "readers/open3d_module.hpp"

#include <open3d/geometry/Image.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/ImageIO.h>
#include <open3d/io/PointCloudIO.h>
#include <open3d/utility/Logging.h>

#include <mutex>

namespace adit::map::readers_internal {
namespace {

// Open3D's logger prints to stdout, adit's result channel: keep its last message for our report.
std::string& lastError() {
  static thread_local std::string last;
  return last;
}

void quiet() {
  static std::once_flag once;
  std::call_once(once, [] {
    auto& logger = open3d::utility::Logger::GetInstance();
    logger.SetPrintFunction([](const std::string& msg) { lastError() = msg; });
    logger.SetVerbosityLevel(open3d::utility::VerbosityLevel::Warning);
  });
  lastError().clear();
}

bool readCloud(const char* path, const char* format, std::vector<double>* xyz, std::string* error) {
  quiet();
  open3d::geometry::PointCloud cloud;
  if (!open3d::io::ReadPointCloud(path, cloud, open3d::io::ReadPointCloudOption(format, false, false))) {
    *error = lastError();
    return false;
  }
  xyz->resize(3 * cloud.points_.size());
  for (std::size_t i = 0; i < cloud.points_.size(); ++i)
    for (int a = 0; a < 3; ++a) (*xyz)[3 * i + std::size_t(a)] = cloud.points_[i][a];
  return true;
}

bool readPng(const unsigned char* data, std::size_t size, Open3dImage* out, std::string* error) {
  quiet();
  open3d::geometry::Image img;
  if (!open3d::io::ReadPNGFromMemory(data, size, img)) {
    *error = lastError();
    return false;
  }
  out->width = img.width_;
  out->height = img.height_;
  out->channels = img.num_of_channels_;
  out->bytes_per_channel = img.bytes_per_channel_;
  out->data = std::move(img.data_);
  return true;
}

}  // namespace
}  // namespace adit::map::readers_internal

extern "C" __attribute__((visibility("default"))) const adit::map::readers_internal::Open3dModule* adit_open3d_module() {
  static const adit::map::readers_internal::Open3dModule module{adit::map::readers_internal::kOpen3dModuleVersion,
                                                                 &adit::map::readers_internal::readCloud,
                                                                 &adit::map::readers_internal::readPng};
  return &module;
}
