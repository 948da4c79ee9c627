// SPDX-License-Identifier: BSD-3-Clause
// The inputs the reader fuzzers (tests/fuzz, label fuzz) found: each broke a reader once, and is
// kept here so the default suite guards the fix. The same bytes are in
// tests/fuzz/regressions/<fuzzer>/, replayed by fuzz_<fuzzer>_regressions.
#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "adit/map/readers/dxf.hpp"
#include "adit/map/readers/las.hpp"
#include "adit/map/readers/mesh.hpp"
#include "adit/map/readers/ply.hpp"
#include "adit/map/readers/ros_map.hpp"
#include "support/synthetic_scan.hpp"

namespace adit::map {
namespace {

// fuzz_dxf_sections: a YAML complex key (a sequence) as the first layer name threw
// YAML::TypedBadConversion out of parseDxfSections.
TEST(FuzzRegressions, DxfSectionsNonScalarLayerNameIsRefused) {
  const std::string text = "sections:\n  ? [a, b]\n  : {shape: rectangle, width: 4, height: 3}\n";
  StatusOr<DxfSections> s = parseDxfSections(text, "sec.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.status().message().find("sec.yaml:2"), std::string::npos) << s.status().message();
  EXPECT_NE(s.status().message().find("layer name"), std::string::npos) << s.status().message();
}

// fuzz_ros_image: PGM sides of 2^32 multiply to 0 in 64 bits; the image "decoded" to 0 x 0 cells.
TEST(FuzzRegressions, PgmSidesThatWrapToZeroPixelsAreRefused) {
  for (const char* header : {"P5 4294967296 4294967296 255\n", "P2 8589934592 2147483648 255\n"}) {
    RosMap m;
    m.resolution_m = 0.25;
    const Status s = decodeRosMapImage(header, "wrap.pgm", &m, 1u << 20);
    ASSERT_FALSE(s.ok()) << header;
    EXPECT_EQ(s.code(), StatusCode::kOutOfRange);
    EXPECT_NE(s.message().find("wrap.pgm"), std::string::npos) << s.message();
    EXPECT_TRUE(m.cells.empty());
  }
}

// fuzz_las: a finite but huge scale (or offset) overflowed the scaled coordinates to infinity and
// the reader returned them as points.
TEST(FuzzRegressions, LasScaleThatOverflowsIsRefused) {
  std::string b = test::las({Vec3(0, 0, 0), Vec3(2000, 0, 0)}, 2);
  const double huge = 1e306;
  std::memcpy(&b[131], &huge, sizeof huge);  // x scale: 2e6 x 1e306 is +inf
  StatusOr<Geometry> g = parseLas(b, "huge.las");
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(g.status().message().find("huge.las: offset 247: point 2"), std::string::npos) << g.status().message();
}

// fuzz_ply: two vertices announced, four given; Assimp read "0 0 1" as a face of no indices and
// its triangulation aborted the process (ai_assert) instead of reporting the file.
TEST(FuzzRegressions, PlyFaceWithoutIndicesIsRefused) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n1 0 1\n0 0 1\n3 0 1 2\n3 0 2 3\n";
  StatusOr<Geometry> g = parseMesh(ply, "lying.ply", "ply");  // Assimp straight away, as for readMesh
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.status().message().find("lying.ply: face 2 of mesh 1 has no vertex indices"), std::string::npos)
      << g.status().message();
  // parsePly checks the body against the header before Assimp sees it.
  g = parsePly(ply, "lying.ply");
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.status().message().find("lying.ply:12: 3 values where a 'face' takes 2"), std::string::npos)
      << g.status().message();
}

// fuzz_ply: Assimp's PLY parser corrupted the heap (ASan's allocator check failed inside
// libassimp) after a run of meshes whose bodies did not match their headers; parsePly now walks
// the body first. Ascii: each element one line of numbers; binary: lists inside the file.
TEST(FuzzRegressions, PlyMeshBodyMustMatchItsHeader) {
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                           "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  ASSERT_TRUE(parsePly(head + "0 0 0\n1 0 0\n1 0 1\n3 0 1 2\n", "ok.ply").ok());
  const std::pair<std::string, std::string> bad[] = {
      {"0 0 0\n1 0 0\n1 0\xff 1\n3 0 1 2\n", "bad.ply:12: '0\xff' is not a number"},
      {"0 0 0\n1 0 0\n1 0 1\n9 0 1 2\n", "bad.ply:13: list length 9.000000 does not fit the line"},
      {"0 0 0\n1 0\n1 0 1\n3 0 1 2\n", "bad.ply:11: too few values for a 'vertex'"},
      {"0 0 0\n1 0 0\n1 0 1\n3 0 1 2 7\n", "bad.ply:13: 5 values where a 'face' takes 4"}};
  for (const auto& [body, message] : bad) {
    StatusOr<Geometry> g = parsePly(head + body, "bad.ply");
    ASSERT_FALSE(g.ok()) << body;
    EXPECT_NE(g.status().message().find(message), std::string::npos) << g.status().message();
  }
  // Binary: three float vertices, then a face whose list claims 200 indices of 4 bytes.
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  bin += std::string(36, '\0') + char(200) + std::string(12, '\0');
  StatusOr<Geometry> g = parsePly(bin, "short.ply");
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.status().message().find("short.ply: truncated: 'face' 1 of 1 runs past the end"), std::string::npos)
      << g.status().message();
}

// One triangle in COLLADA; `count` is the float_array's count attribute ("" leaves it out), `p`
// the triangle's indices.
std::string dae(const std::string& count, const std::string& p = "0 1 2") {
  return "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
         "<library_geometries><geometry id=\"g\"><mesh>\n<source id=\"p\"><float_array id=\"pa\"" + count +
         ">0 0 0 1 0 0 1 0 1</float_array>\n<technique_common><accessor source=\"#pa\" count=\"3\" stride=\"3\">"
         "<param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/>"
         "</accessor></technique_common></source>\n<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>\n"
         "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>" + p + "</p></triangles>\n"
         "</mesh></geometry></library_geometries>\n<library_visual_scenes><visual_scene id=\"s\"><node id=\"n\">"
         "<instance_geometry url=\"#g\"/></node></visual_scene></library_visual_scenes>\n"
         "<scene><instance_visual_scene url=\"#s\"/></scene>\n</COLLADA>\n";
}

// fuzz_mesh: a float_array without `count` holds no values for Assimp, whose accessor then read
// through a null pointer (SEGV inside libassimp).
TEST(FuzzRegressions, DaeAccessorPastItsArrayIsRefused) {
  StatusOr<Geometry> good = parseMesh(dae(" count=\"9\""), "ok.dae", "dae");
  ASSERT_TRUE(good.ok()) << good.status().message();
  EXPECT_EQ(good->triangles.size(), 1u);
  for (const char* count : {"", " count=\"8\"", " count=\"-1\""}) {
    StatusOr<Geometry> g = parseMesh(dae(count), "short.dae", "dae");
    ASSERT_FALSE(g.ok()) << count;
    EXPECT_NE(g.status().message().find("accessor of 'pa' reads 3 x 3 values"), std::string::npos)
        << g.status().message();
  }
  EXPECT_FALSE(parseMesh("<COLLADA><unclosed", "bad.dae", "dae").ok());
}

// fuzz_mesh: <triangles count="1"> whose <p> held "0 \x11 2"; Assimp's index parser stalled on
// the token and allocated 4.8 GB. The indices must be integers, as many as the element announces.
TEST(FuzzRegressions, DaePrimitiveIndicesMustMatchTheirCount) {
  const std::pair<const char*, const char*> bad[] = {
      {"0 \x11 2", "<triangles> <p> holds something other than vertex indices"},
      {"0 -1 2", "<triangles> <p> holds something other than vertex indices"},
      {"0 2", "<triangles> announces 3 indices, its <p> holds 2"},
      {"0 1 2 0", "<triangles> announces 3 indices, its <p> holds 4"}};
  for (const auto& [p, message] : bad) {
    StatusOr<Geometry> g = parseMesh(dae(" count=\"9\"", p), "prim.dae", "dae");
    ASSERT_FALSE(g.ok()) << p;
    EXPECT_NE(g.status().message().find(message), std::string::npos) << g.status().message();
  }
}

}  // namespace
}  // namespace adit::map
