// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/ros_map.hpp"

#include <octomap/OcTree.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "adit/map/map_io.hpp"
#include "common.hpp"
#include "voxel_blocks.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {

std::string where(const std::string& name, const YAML::Node& n, const std::string& field) {
  const YAML::Mark m = n.Mark();
  std::ostringstream os;
  os << name;
  if (m.line >= 0) os << ":" << m.line + 1 << ":" << m.column + 1;
  os << ": " << field;
  return os.str();
}

StatusOr<double> number(const YAML::Node& root, const char* field, const std::string& name, bool required,
                        double fallback) {
  const YAML::Node n = root[field];
  if (!n) {
    if (required) return invalidArgument(name + ": missing field '" + field + "'");
    return fallback;
  }
  double v = 0;
  if (!n.IsScalar() || !YAML::convert<double>::decode(n, v) || !std::isfinite(v))
    return invalidArgument(where(name, n, field) + ": expected a finite number");
  return v;
}

// Netpbm grey image: P5 (binary) or P2 (ascii), maxval up to 65535; values scaled to 0..255.
Status decodePgm(const std::string& b, const std::string& name, std::uint64_t max_pixels, std::vector<int>* grey,
                 int* w, int* h) {
  std::size_t pos = 2;
  std::uint64_t v[3];
  for (int i = 0; i < 3; ++i) {
    while (pos < b.size()) {
      if (std::isspace(static_cast<unsigned char>(b[pos]))) ++pos;
      else if (b[pos] == '#') { while (pos < b.size() && b[pos] != '\n') ++pos; }
      else break;
    }
    std::size_t start = pos;
    while (pos < b.size() && std::isdigit(static_cast<unsigned char>(b[pos])) && pos - start < 10) ++pos;
    if (pos == start) return invalidArgument(at(name, start) + ": PGM header: expected a number");
    v[i] = std::stoull(b.substr(start, pos - start));
  }
  if (v[0] == 0 || v[1] == 0 || v[2] == 0 || v[2] > 65535)
    return invalidArgument(name + ": PGM header: width, height and maxval must be positive (maxval <= 65535)");
  // Each side first: 10 digits reach 2^32, and 2^32 x 2^32 wraps to 0 pixels in 64 bits.
  if (v[0] > max_pixels || v[1] > max_pixels || v[0] * v[1] > max_pixels)
    return outOfRange(name + ": PGM of " + std::to_string(v[0]) + " x " + std::to_string(v[1]) +
                      " pixels exceeds the limit of " + std::to_string(max_pixels));
  *w = int(v[0]);
  *h = int(v[1]);
  const std::uint64_t n = v[0] * v[1];
  grey->resize(n);
  const bool binary = b[1] == '5';
  if (binary) {
    ++pos;  // the single whitespace after maxval
    const std::uint64_t bpp = v[2] > 255 ? 2 : 1;
    if (b.size() < pos || b.size() - pos < n * bpp)
      return dataLoss(at(name, pos) + ": truncated PGM: " + std::to_string(n * bpp) + " bytes of pixels expected, " +
                      std::to_string(b.size() > pos ? b.size() - pos : 0) + " follow");
    for (std::uint64_t i = 0; i < n; ++i) {
      const unsigned raw = bpp == 1 ? static_cast<unsigned char>(b[pos + i])
                                    : (unsigned(static_cast<unsigned char>(b[pos + 2 * i])) << 8) |
                                          static_cast<unsigned char>(b[pos + 2 * i + 1]);
      if (raw > v[2]) return invalidArgument(at(name, pos + i * bpp) + ": pixel value above maxval");
      (*grey)[i] = int(std::lround(255.0 * raw / double(v[2])));
    }
  } else {
    for (std::uint64_t i = 0; i < n; ++i) {
      while (pos < b.size() && std::isspace(static_cast<unsigned char>(b[pos]))) ++pos;
      std::size_t start = pos;
      while (pos < b.size() && std::isdigit(static_cast<unsigned char>(b[pos])) && pos - start < 6) ++pos;
      if (pos == start) return dataLoss(at(name, start) + ": PGM pixel " + std::to_string(i + 1) + " missing or not a number");
      const std::uint64_t raw = std::stoull(b.substr(start, pos - start));
      if (raw > v[2]) return invalidArgument(at(name, start) + ": pixel value above maxval");
      (*grey)[i] = int(std::lround(255.0 * double(raw) / double(v[2])));
    }
  }
  return {};
}

// yaml-cpp throws; its marks are 0-based.
StatusOr<YAML::Node> loadYaml(const std::string& text, const std::string& name) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return invalidArgument(name + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                           ": YAML error: " + e.msg);
  } catch (const std::exception& e) {
    return invalidArgument(name + ": YAML error: " + e.what());
  }
}

}  // namespace

bool isRosMapYaml(const std::string& text) {
  StatusOr<YAML::Node> root = loadYaml(text, "");
  return root.ok() && root->IsMap() && (*root)["image"] && !(*root)["stations"];
}

StatusOr<RosMap> parseRosMapYaml(const std::string& text, const std::string& name) {
  ADIT_ASSIGN_OR_RETURN(const YAML::Node root, loadYaml(text, name));
  if (!root.IsMap()) return invalidArgument(name + ": a map_server YAML must be a mapping");
  RosMap m;
  const YAML::Node image = root["image"];
  if (!image || !image.IsScalar() || image.Scalar().empty())
    return invalidArgument(name + ": missing field 'image' (the map's PGM or PNG)");
  m.image = image.Scalar();
  ADIT_ASSIGN_OR_RETURN(m.resolution_m, number(root, "resolution", name, true, 0));
  if (m.resolution_m <= 0) return invalidArgument(where(name, root["resolution"], "resolution") + ": must be > 0");
  ADIT_ASSIGN_OR_RETURN(m.occupied_thresh, number(root, "occupied_thresh", name, false, 0.65));
  ADIT_ASSIGN_OR_RETURN(m.free_thresh, number(root, "free_thresh", name, false, 0.196));
  if (!(m.free_thresh >= 0 && m.free_thresh <= m.occupied_thresh && m.occupied_thresh <= 1))
    return invalidArgument(name + ": need 0 <= free_thresh <= occupied_thresh <= 1");
  const YAML::Node origin = root["origin"];
  if (!origin || !origin.IsSequence() || origin.size() != 3)
    return invalidArgument((origin ? where(name, origin, "origin") : name + ": origin") + ": expected [x, y, yaw]");
  double o[3];
  for (std::size_t i = 0; i < 3; ++i)
    if (!YAML::convert<double>::decode(origin[i], o[i]) || !std::isfinite(o[i]))
      return invalidArgument(where(name, origin[i], "origin[" + std::to_string(i) + "]") + ": expected a finite number");
  m.origin_x = o[0];
  m.origin_y = o[1];
  m.origin_yaw = o[2];
  if (const YAML::Node n = root["negate"]) {
    int neg = 0;
    bool b = false;
    if (YAML::convert<int>::decode(n, neg) && (neg == 0 || neg == 1)) m.negate = neg == 1;
    else if (YAML::convert<bool>::decode(n, b)) m.negate = b;
    else return invalidArgument(where(name, n, "negate") + ": expected 0 or 1");
  }
  if (const YAML::Node n = root["mode"]) {
    if (!n.IsScalar() || (n.Scalar() != "trinary" && n.Scalar() != "scale"))
      return invalidArgument(where(name, n, "mode") + ": only 'trinary' and 'scale' maps can be extruded (got '" +
                             (n.IsScalar() ? n.Scalar() : std::string("?")) + "')");
  }
  return m;
}

Status decodeRosMapImage(const std::string& b, const std::string& name, RosMap* m, std::uint64_t max_pixels) {
  std::vector<int> grey, alpha;
  int w = 0, h = 0;
  if (b.size() >= 2 && b[0] == 'P' && (b[1] == '5' || b[1] == '2')) {
    ADIT_RETURN_IF_ERROR(decodePgm(b, name, max_pixels, &grey, &w, &h));
  } else if (b.size() >= 8 && b.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0) {
    if (b.size() < 24) return dataLoss(name + ": truncated PNG header");
    auto be32 = [&](std::size_t o) {
      return (std::uint64_t(static_cast<unsigned char>(b[o])) << 24) | (std::uint64_t(static_cast<unsigned char>(b[o + 1])) << 16) |
             (std::uint64_t(static_cast<unsigned char>(b[o + 2])) << 8) | std::uint64_t(static_cast<unsigned char>(b[o + 3]));
    };
    const std::uint64_t pw = be32(16), ph = be32(20);
    if (pw == 0 || ph == 0 || pw * ph > max_pixels)
      return outOfRange(at(name, 16) + ": PNG of " + std::to_string(pw) + " x " + std::to_string(ph) +
                        " pixels is empty or exceeds the limit of " + std::to_string(max_pixels));
    ADIT_ASSIGN_OR_RETURN(const Open3dModule* o3d, open3dModule());
    Open3dImage img;
    std::string why;
    if (!o3d->read_png(reinterpret_cast<const unsigned char*>(b.data()), b.size(), &img, &why) || img.width <= 0 ||
        img.height <= 0)
      return dataLoss(name + ": cannot decode the PNG" + open3dWhy(why));
    w = img.width;
    h = img.height;
    const int ch = img.channels, bpc = img.bytes_per_channel;
    const bool has_alpha = ch == 2 || ch == 4;
    const int colours = has_alpha ? ch - 1 : ch;
    grey.resize(std::size_t(w) * std::size_t(h));
    alpha.assign(grey.size(), 255);
    for (std::size_t i = 0; i < grey.size(); ++i) {
      auto sample = [&](int c) {
        const std::uint8_t* p = img.data.data() + (i * std::size_t(ch) + std::size_t(c)) * std::size_t(bpc);
        return bpc == 2 ? int(((unsigned(p[0]) << 8) | p[1]) >> 8) : int(p[0]);
      };
      int sum = 0;
      for (int c = 0; c < colours; ++c) sum += sample(c);
      grey[i] = sum / colours;
      if (has_alpha) alpha[i] = sample(ch - 1);
    }
  } else {
    return invalidArgument(at(name, 0) + ": not a PGM (P2/P5) or PNG image");
  }
  m->width = w;
  m->height = h;
  m->cells.resize(grey.size());
  for (std::size_t i = 0; i < grey.size(); ++i) {
    const double occ = m->negate ? grey[i] / 255.0 : (255 - grey[i]) / 255.0;
    if (!alpha.empty() && alpha[i] < 255) m->cells[i] = -1;
    else if (occ > m->occupied_thresh) m->cells[i] = 100;
    else if (occ < m->free_thresh) m->cells[i] = 0;
    else m->cells[i] = -1;
  }
  return {};
}

StatusOr<RosMap> readRosMap(const std::string& yaml_path) {
  ADIT_ASSIGN_OR_RETURN(std::string text, readFile(yaml_path, std::size_t{1} << 20));
  ADIT_ASSIGN_OR_RETURN(RosMap m, parseRosMapYaml(text, yaml_path));
  std::filesystem::path img(m.image);
  if (img.is_relative()) img = std::filesystem::path(yaml_path).parent_path() / img;
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(img.string()));
  ADIT_RETURN_IF_ERROR(decodeRosMapImage(bytes, img.string(), &m));
  return m;
}

StatusOr<OccupancyMap> extrudeRosMap(const RosMap& m, const ExtrudeOptions& o) {
  const double res = o.resolution_m > 0 ? o.resolution_m : m.resolution_m;
  ADIT_RETURN_IF_ERROR(checkResolution(res));
  if (!std::isfinite(o.height_m) || o.height_m < res)
    return invalidArgument("extrusion height must be at least one voxel (" + std::to_string(res) + " m)");
  if (m.cells.size() != std::size_t(m.width) * std::size_t(m.height) || m.cells.empty())
    return invalidArgument("the map has no cells");
  // Pixel centres (sub-sampled when voxels are finer than pixels), rotated by yaw about the origin.
  const int sub = std::max(1, int(std::ceil(m.resolution_m / res)));
  const double c = std::cos(m.origin_yaw), s = std::sin(m.origin_yaw);
  const int layers = int(std::ceil(o.height_m / res - 1e-9));
  std::uint64_t known = 0;
  for (std::int8_t v : m.cells) known += v >= 0;
  const double estimate = double(known) * sub * sub * layers;
  if (estimate > double(o.max_voxels)) {
    std::ostringstream os;
    os << "extruding " << known << " known pixels to " << o.height_m << " m needs about " << estimate
       << " voxels (limit " << o.max_voxels << "); use a coarser --resolution or a lower --height";
    return outOfRange(os.str());
  }
  auto world = [&](double px, double py) -> Vec3 {
    return Vec3(m.origin_x + c * px - s * py, m.origin_y + s * px + c * py, 0.0) - o.shift;
  };
  Aabb box;
  for (double px : {0.0, m.width * m.resolution_m})
    for (double py : {0.0, m.height * m.resolution_m}) box.extend(world(px, py));
  box.extend(Vec3(box.min.x(), box.min.y(), -o.shift.z() + o.height_m));
  box.min.z() = -o.shift.z();
  ADIT_RETURN_IF_ERROR(checkExtent(box, res));
  auto tree = std::make_shared<octomap::OcTree>(res);
  const float free_v = tree->getClampingThresMinLog(), occ_v = tree->getClampingThresMaxLog();
  // Occupied wins where a voxel straddles a free and an occupied pixel: write free first.
  for (std::int8_t pass : {std::int8_t(0), std::int8_t(100)})
    for (int row = 0; row < m.height; ++row)
      for (int col = 0; col < m.width; ++col) {
        if (m.cells[std::size_t(row) * std::size_t(m.width) + std::size_t(col)] != pass) continue;
        const int iy = m.height - 1 - row;  // image rows run north to south
        for (int a = 0; a < sub; ++a)
          for (int b2 = 0; b2 < sub; ++b2) {
            const Vec3 p = world((col + (a + 0.5) / sub) * m.resolution_m, (iy + (b2 + 0.5) / sub) * m.resolution_m);
            for (int k = 0; k < layers; ++k) {
              const octomap::OcTreeKey key = tree->coordToKey(p.x(), p.y(), -o.shift.z() + (k + 0.5) * res);
              tree->setNodeValue(key, pass ? occ_v : free_v, /*lazy_eval=*/true);
            }
          }
      }
  tree->updateInnerOccupancy();
  tree->prune();
  return OccupancyMap::create(std::move(tree), o.unknown_policy);
}

}  // namespace adit::map
