// SPDX-License-Identifier: BSD-3-Clause
// Writes the fuzzers' seed corpora from the repository's own data: small .bt/.ot maps voxelized
// from the test surveys and cut from maps/district.bt, the survey YAML files, the points CSVs;
// for the import readers, small files of every format written here (Open3D writes the PCD, PLY
// and PNG variants, tests/support's encoders LAS, STL and OBJ, the rest is spelled out here) plus
// the tests/tools/data fixtures.
// Usage: adit_fuzz_seeds MAPS_DIR TOOLS_DATA_DIR OUT_DIR  (writes OUT_DIR/<fuzzer>/...)
#include <open3d/geometry/Image.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/ImageIO.h>
#include <open3d/io/PointCloudIO.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "adit/map/map_io.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"
#include "support/synthetic_scan.hpp"

namespace fs = std::filesystem;
using namespace adit::map;
namespace test = adit::test;

namespace {

constexpr std::uintmax_t kMaxSeedBytes = 16 * 1024;

bool ok(const adit::Status& s, const std::string& what) {
  if (!s.ok()) std::fprintf(stderr, "adit_fuzz_seeds: %s: %s\n", what.c_str(), s.message().c_str());
  return s.ok();
}

// Both OctoMap formats of `map`, as <stem>.bt and <stem>.ot.
bool writeBoth(const OccupancyMap& map, const fs::path& dir, const std::string& stem) {
  return ok(writeOctomap(map, (dir / (stem + ".bt")).string()), stem) &&
         ok(writeOctomap(map, (dir / (stem + ".ot")).string()), stem);
}

void writeBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary) << bytes;
}

// The first `lines` lines of a fixture (the big ones would slow every execution down).
std::string head(const fs::path& file, int lines) {
  std::ifstream in(file, std::ios::binary);
  std::string out, l;
  for (int i = 0; i < lines && std::getline(in, l); ++i) out += l + "\n";
  return out;
}

std::string slurp(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A short roadway scan: two rings of 8 points around the x axis, 1 m apart.
std::vector<Vec3> ringScan() {
  std::vector<Vec3> pts;
  for (int x = 0; x < 2; ++x)
    for (int k = 0; k < 8; ++k) pts.emplace_back(x, 1.5 * std::cos(k * M_PI / 4), 1.5 + 1.5 * std::sin(k * M_PI / 4));
  return pts;
}

// Seeds for the import readers, in OUT/<fuzzer>/; `data` is tests/tools/data.
bool writeReaderSeeds(const fs::path& data, const fs::path& out) {
  const char* dirs[] = {"pcd", "ply", "xyz", "las", "mesh", "geometry", "dxf", "dxf_sections", "ros_yaml", "ros_image", "trajectory"};
  for (const char* d : dirs) fs::create_directories(out / d);
  bool good = true;
  const std::vector<Vec3> scan = ringScan();
  // Every point and mesh seed also goes to the dispatcher's corpus, behind its extension's selector.
  const auto both = [&](const char* fuzzer, const std::string& file, const std::string& bytes, int ext_selector) {
    writeBytes(out / fuzzer / file, bytes);
    writeBytes(out / "geometry" / file, std::string(1, char(ext_selector)) + bytes);
  };

  open3d::geometry::PointCloud cloud;
  cloud.points_ = scan;
  const auto o3d = [&](const fs::path& file, bool ascii, bool compressed) {
    if (open3d::io::WritePointCloud(file.string(), cloud, open3d::io::WritePointCloudOption(ascii, compressed))) return true;
    std::fprintf(stderr, "adit_fuzz_seeds: Open3D could not write %s\n", file.c_str());
    return false;
  };
  good = o3d(out / "pcd" / "ring_ascii.pcd", true, false) && o3d(out / "pcd" / "ring_binary.pcd", false, false) &&
         o3d(out / "pcd" / "ring_compressed.pcd", false, true) && o3d(out / "ply" / "ring_ascii.ply", true, false) &&
         o3d(out / "ply" / "ring_binary.ply", false, false) && good;
  std::ostringstream pcd;  // more field types than Open3D writes, and a viewpoint
  pcd << "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity rgb\nSIZE 8 8 8 2 4\nTYPE F F F U U\nCOUNT 1 1 1 1 1\n"
      << "WIDTH 4\nHEIGHT 1\nVIEWPOINT 1 0 1.5 1 0 0 0\nPOINTS 4\nDATA ascii\n";
  for (int i = 0; i < 4; ++i) pcd << scan[i].x() << " " << scan[i].y() << " " << scan[i].z() << " " << 100 * i << " 4285887402\n";
  writeBytes(out / "pcd" / "fields.pcd", pcd.str());
  {  // the fixture's 11 header lines and its first 49 points
    std::string tube = head(data / "tube_viewpoint.pcd", 60);
    for (std::size_t at; (at = tube.find("1100")) != std::string::npos;) tube.replace(at, 4, "49");
    writeBytes(out / "pcd" / "tube_viewpoint.pcd", tube);
  }
  std::string bigendian = "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
                          "property double z\nend_header\n";
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) {
      std::uint64_t bits;
      std::memcpy(&bits, &scan[i][k], 8);
      for (int byte = 7; byte >= 0; --byte) bigendian += char((bits >> (8 * byte)) & 0xff);
    }
  writeBytes(out / "ply" / "ring_big_endian.ply", bigendian);
  const std::string ply_mesh = "ply\nformat ascii 1.0\ncomment a wall patch\nelement vertex 4\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                               "end_header\n0 0 0\n1 0 0\n1 0 1\n0 0 1\n3 0 1 2\n3 0 2 3\n";
  writeBytes(out / "ply" / "patch_mesh.ply", ply_mesh);
  for (const auto& e : fs::directory_iterator(out / "pcd")) both("pcd", e.path().filename().string(), slurp(e.path()), 0);
  for (const auto& e : fs::directory_iterator(out / "ply")) both("ply", e.path().filename().string(), slurp(e.path()), 1);

  std::ostringstream xyz;
  xyz << "x;y;z;intensity\n";
  for (const Vec3& p : scan) xyz << "+" << p.x() << ";" << p.y() << ";" << p.z() << ";7\n";
  both("xyz", "ring_semicolons.csv", xyz.str(), 3);
  both("xyz", "tube.xyz", head(data / "tube.xyz", 40), 2);
  both("xyz", "tube_utm.csv", head(data / "tube_utm.csv", 40), 3);
  for (const char* f : {"points.csv", "bom_points.csv", "bad_points.csv"}) both("xyz", f, head(data / f, 100), 3);

  both("las", "ring_1_2.las", test::las(scan, 2), 4);
  both("las", "ring_1_4_utm.las", test::las(scan, 4, Vec3(500000, 4000000, 0)), 4);
  both("las", "scan.laz", slurp(data / "scan.laz"), 5);

  // Meshes: the first byte is fuzz_mesh's format selector (0 stl, 1 obj, 2 ply, 3 dae).
  test::TubeScan tube;
  tube.length = 2.0;
  const Geometry tube_mesh = tube.mesh();
  const std::string obj = "# wall patch\no patch\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvn 0 -1 0\nf 1//1 2//1 3//1 4//1\n";
  const std::string dae =
      "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
      "<asset><unit meter=\"1\"/><up_axis>Z_UP</up_axis></asset>\n"
      "<library_geometries><geometry id=\"g\"><mesh>\n"
      "<source id=\"p\"><float_array id=\"pa\" count=\"9\">0 0 0 1 0 0 1 0 1</float_array>\n"
      "<technique_common><accessor source=\"#pa\" count=\"3\" stride=\"3\"><param name=\"X\" type=\"float\"/>"
      "<param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/></accessor></technique_common></source>\n"
      "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>\n"
      "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 2</p></triangles>\n"
      "</mesh></geometry></library_geometries>\n"
      "<library_visual_scenes><visual_scene id=\"s\"><node id=\"n\"><matrix>1 0 0 0 0 1 0 0 0 0 1 2 0 0 0 1</matrix>"
      "<instance_geometry url=\"#g\"/></node></visual_scene></library_visual_scenes>\n"
      "<scene><instance_visual_scene url=\"#s\"/></scene>\n</COLLADA>\n";
  const std::pair<const char*, std::pair<int, std::string>> meshes[] = {
      {"tube_ascii.stl", {0, test::stlAscii(tube_mesh)}},
      {"tube_binary.stl", {0, test::stlBinary(tube_mesh)}},
      {"tube.obj", {1, test::objText(tube_mesh)}},
      {"wall_quad.obj", {1, obj}},
      {"wall.ply", {2, ply_mesh}},
      {"wall.dae", {3, dae}}};
  const int mesh_ext[] = {6, 7, 1, 8};  // the same files behind fuzz_geometry's .stl/.obj/.ply/.dae
  for (const auto& [file, m] : meshes) {
    writeBytes(out / "mesh" / file, std::string(1, char(m.first)) + m.second);
    writeBytes(out / "geometry" / (std::string("mesh_") + file), std::string(1, char(mesh_ext[m.first])) + m.second);
  }

  for (const char* f : {"centrelines.dxf", "tube_faces.dxf"}) fs::copy_file(data / f, out / "dxf" / f, fs::copy_options::overwrite_existing);
  std::ostringstream dxf;  // a closed LWPOLYLINE, a 3-D POLYLINE and a LINE, in a full SECTION layout
  dxf << "0\nSECTION\n2\nHEADER\n9\n$ACADVER\n1\nAC1015\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n"
      << "0\nLWPOLYLINE\n8\nLOOP\n90\n4\n70\n1\n38\n-50\n10\n0\n20\n0\n10\n30\n20\n0\n10\n30\n20\n30\n10\n0\n20\n30\n"
      << "0\nPOLYLINE\n8\nRAMP\n66\n1\n70\n8\n0\nVERTEX\n8\nRAMP\n10\n30\n20\n0\n30\n-50\n0\nVERTEX\n8\nRAMP\n10\n60\n20\n0\n30\n-40\n0\nSEQEND\n"
      << "0\nLINE\n8\n0\n10\n0\n20\n0\n30\n0\n11\n1\n21\n1\n31\n0\n0\nENDSEC\n0\nEOF\n";
  writeBytes(out / "dxf" / "loop_ramp.dxf", dxf.str());

  fs::copy_file(data / "centrelines_sections.yaml", out / "dxf_sections" / "centrelines_sections.yaml",
                fs::copy_options::overwrite_existing);
  writeBytes(out / "dxf_sections" / "all_shapes.yaml",
             "resolution: 0.5\nrock_shell: 1.0\nsections:\n  MAIN: {shape: arch, width: 5.0, wall_height: 3.0}\n"
             "  DRIFT: {shape: rectangle, width: 4.0, height: 3.0}\n  RAMP: {shape: trapezoid, bottom_width: 5, top_width: 4, height: 3}\n"
             "  SHAFT: {shape: three_centred_arch, width: 6, wall_height: 2.5, rise: 2}\n");
  writeBytes(out / "dxf_sections" / "spec_rectangle.txt", "{shape: rectangle, width: 4, height: 3}");
  writeBytes(out / "dxf_sections" / "spec_arch.txt", "{shape: arch, width: 5, wall_height: 3}");

  fs::copy_file(data / "room.yaml", out / "ros_yaml" / "room.yaml", fs::copy_options::overwrite_existing);
  writeBytes(out / "ros_yaml" / "scale.yaml", "image: \"maps/level 2.png\"\nmode: scale\nresolution: 0.05\n"
                                              "origin: [-10.5, 3.25, 1.5708]\nnegate: true\noccupied_thresh: 0.9\nfree_thresh: 0.1\n");

  // Images: the first byte is fuzz_ros_image's selector (negate, resolution, yaw bits).
  writeBytes(out / "ros_image" / "room.pgm", std::string(1, '\0') + slurp(data / "room.pgm"));
  std::ostringstream p2;
  p2 << "P2\n# a 6 x 4 room\n6 4\n65535\n";
  for (int i = 0; i < 24; ++i) p2 << (i % 7 == 0 ? 0 : i % 5 == 0 ? 30000 : 65535) << (i % 6 == 5 ? "\n" : " ");
  writeBytes(out / "ros_image" / "room_p2_16bit.pgm", std::string(1, '\3') + p2.str());
  for (int channels : {1, 2, 4}) {
    open3d::geometry::Image img;
    img.Prepare(5, 4, channels, 1);
    for (std::size_t i = 0; i < img.data_.size(); ++i) img.data_[i] = std::uint8_t((i * 53) % 256);
    const fs::path png = out / "ros_image" / ("room_" + std::to_string(channels) + "ch.png");
    if (!open3d::io::WriteImageToPNG(png.string(), img)) {
      std::fprintf(stderr, "adit_fuzz_seeds: Open3D could not write %s\n", png.c_str());
      good = false;
      continue;
    }
    writeBytes(png, std::string(1, char(channels)) + slurp(png));
  }

  writeBytes(out / "trajectory" / "xyz.csv", "0,0,1.5\n1,0,1.5\n2,0.1,1.5\n");
  writeBytes(out / "trajectory" / "poses7.txt", "0 0 1.5 0 0 0 1\n1 0 1.5 0 0 0.1 0.995\n");
  writeBytes(out / "trajectory" / "tum.txt", "# timestamp tx ty tz qx qy qz qw\n1.0 0 0 1.5 0 0 0 1\n1.1 0.5 0 1.5 0 0 0 1\n");
  writeBytes(out / "trajectory" / "header.csv", "\xEF\xBB\xBFtime;x;y;z;roll\n0;0;0;1.5;0\n1;1;0;1.5;0\n");
  return good;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s MAPS_DIR TOOLS_DATA_DIR OUT_DIR\n", argv[0]);
    return 2;
  }
  const fs::path maps = argv[1], data = argv[2], out = argv[3];
  const fs::path octomap = out / "octomap", survey = out / "survey", csv = out / "points_csv";
  for (const fs::path& d : {octomap, survey, csv}) fs::create_directories(d);
  bool good = true;

  // Surveys and CSVs as they are; the YAML ones also voxelized coarsely into small octrees.
  for (const fs::path& dir : {maps, data})
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".yaml") {
        fs::copy_file(e.path(), survey / e.path().filename(), fs::copy_options::overwrite_existing);
        adit::StatusOr<SurveyNetwork> net = loadSurvey(e.path().string());
        if (!net.ok()) continue;  // the malformed examples are seeds for the survey fuzzer only
        for (double res : {1.0, 0.5}) {
          net->resolution_m = res;
          net->rock_shell_m = res;
          if (net->estimatedVoxels() > 2e6) continue;
          adit::StatusOr<OccupancyMap> map = voxelize(*net);
          good = ok(map.status(), e.path().string()) && good;
          if (map.ok())
            good = writeBoth(*map, octomap, e.path().stem().string() + "_" + std::to_string(int(res * 10))) && good;
        }
      } else if (ext == ".csv") {
        fs::copy_file(e.path(), csv / e.path().filename(), fs::copy_options::overwrite_existing);
      } else if (ext == ".bt" && fs::file_size(e.path()) < 4096) {
        fs::copy_file(e.path(), octomap / e.path().filename(), fs::copy_options::overwrite_existing);
      }
    }

  // Small pieces of the bundled district: a straight roadway and a junction.
  adit::StatusOr<OccupancyMap> district = loadMap((maps / "district.bt").string());
  if (ok(district.status(), "district.bt")) {
    const Aabb pieces[] = {Aabb(Vec3(10, -3, -1), Vec3(13, 3, 4)), Aabb(Vec3(-4, -4, -1), Vec3(4, 4, 4))};
    for (int i = 0; i < 2; ++i) {
      adit::StatusOr<OccupancyMap> part = cropMap(*district, pieces[i]);
      if (ok(part.status(), "district crop")) good = writeBoth(*part, octomap, "district_piece" + std::to_string(i)) && good;
    }
  }
  good = writeReaderSeeds(data, out) && good;
  // Large seeds slow every execution down (libFuzzer mutates whole inputs): keep the small ones.
  for (const auto& dir : fs::directory_iterator(out))
    if (dir.is_directory())
      for (const auto& e : fs::directory_iterator(dir.path()))
        if (fs::file_size(e.path()) > kMaxSeedBytes) fs::remove(e.path());
  return good ? 0 : 1;
}
