// SPDX-License-Identifier: BSD-3-Clause
// DXF through dxflib, on drawings the test writes: LWPOLYLINE at its elevation and 3-D POLYLINE
// centrelines become a survey network (shared junction stations, sections by layer), 3DFACEs a
// mesh; missing sections, bad section specs and empty or broken files are refused by name.
#include <gtest/gtest.h>

#include <sstream>

#include "adit/map/readers/dxf.hpp"

namespace adit::map {
namespace {

std::string lwpolyline(const std::string& layer, const std::vector<std::pair<double, double>>& pts, double elev,
                       bool closed = false) {
  std::ostringstream os;
  os << "0\nLWPOLYLINE\n8\n" << layer << "\n90\n" << pts.size() << "\n70\n" << (closed ? 1 : 0) << "\n38\n" << elev << "\n";
  for (const auto& [x, y] : pts) os << "10\n" << x << "\n20\n" << y << "\n";
  return os.str();
}

std::string polyline3d(const std::string& layer, const std::vector<Vec3>& pts) {
  std::ostringstream os;
  os << "0\nPOLYLINE\n8\n" << layer << "\n66\n1\n70\n8\n10\n0\n20\n0\n30\n0\n";
  for (const Vec3& p : pts)
    os << "0\nVERTEX\n8\n" << layer << "\n10\n" << p.x() << "\n20\n" << p.y() << "\n30\n" << p.z() << "\n70\n32\n";
  os << "0\nSEQEND\n8\n" << layer << "\n";
  return os.str();
}

std::string face(const std::vector<Vec3>& c) {
  std::ostringstream os;
  os << "0\n3DFACE\n8\nWALLS\n";
  for (int i = 0; i < 4; ++i) {
    const Vec3& p = c[std::size_t(std::min(i, int(c.size()) - 1))];
    os << 10 + i << "\n" << p.x() << "\n" << 20 + i << "\n" << p.y() << "\n" << 30 + i << "\n" << p.z() << "\n";
  }
  return os.str();
}

std::string dxf(const std::string& entities) { return "0\nSECTION\n2\nENTITIES\n" + entities + "0\nENDSEC\n0\nEOF\n"; }

TEST(Dxf, CentrelinesBecomeASurveyNetwork) {
  StatusOr<DxfContents> d = parseDxf(dxf(lwpolyline("MAIN", {{0, 0}, {40, 0}, {40, 30}}, -100) +
                                         polyline3d("RAMP", {{40, 0, -100}, {40, -20, -97}})),
                                     "net.dxf");
  ASSERT_TRUE(d.ok()) << d.status().message();
  ASSERT_EQ(d->polylines.size(), 2u);
  EXPECT_EQ(d->polylines[0].layer, "MAIN");
  EXPECT_EQ(d->polylines[0].points[1], Vec3(40, 0, -100));  // the LWPOLYLINE's elevation
  EXPECT_EQ(d->polylines[1].points[1], Vec3(40, -20, -97));  // 3-D vertices
  StatusOr<DxfSections> s = parseDxfSections("resolution: 0.25\nsections:\n  MAIN: {shape: arch, width: 5, wall_height: 3}\n",
                                             "sections.yaml");
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->resolution_m.value_or(0), 0.25);
  StatusOr<CrossSection> ramp = parseSectionSpec("{shape: rectangle, width: 4, height: 3}");
  ASSERT_TRUE(ramp.ok()) << ramp.status().message();
  StatusOr<SurveyNetwork> net = dxfToSurvey(*d, *s, *ramp, 0.2);
  ASSERT_TRUE(net.ok()) << net.status().message();
  EXPECT_EQ(net->resolution_m, 0.25);
  EXPECT_EQ(net->stations.size(), 4u);  // (40, 0, -100) is shared by both roadways
  EXPECT_NEAR(net->totalLength(), 70 + std::hypot(20.0, 3.0), 1e-9);
  EXPECT_EQ(net->sections.at("MAIN").shape(), SectionShape::kArch);
  EXPECT_EQ(net->sections.at("RAMP").shape(), SectionShape::kRectangle);
  StatusOr<OccupancyMap> map = voxelize(*net);
  ASSERT_TRUE(map.ok()) << map.status().message();
  EXPECT_TRUE(map->isFree({20, 0, -98.5}));
  EXPECT_TRUE(map->isFree({40, -10, -97}));
}

TEST(Dxf, MissingSectionsAreNamed) {
  StatusOr<DxfContents> d = parseDxf(dxf(lwpolyline("DRIFT", {{0, 0}, {10, 0}}, 0)), "d.dxf");
  ASSERT_TRUE(d.ok());
  StatusOr<SurveyNetwork> net = dxfToSurvey(*d, {}, std::nullopt, 0.2);
  ASSERT_FALSE(net.ok());
  EXPECT_NE(net.status().message().find("layer 'DRIFT'"), std::string::npos);
  StatusOr<CrossSection> bad = parseSectionSpec("{shape: circle, width: 4}");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("--section:"), std::string::npos) << bad.status().message();
  StatusOr<DxfSections> s = parseDxfSections("sections:\n  MAIN: {shape: arch, width: -5, wall_height: 3}\n", "s.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("s.yaml:2:"), std::string::npos) << s.status().message();
  EXPECT_FALSE(parseDxfSections("resolution: 0.2\n", "t.yaml").ok());
  EXPECT_FALSE(parseDxfSections("sections: [unclosed\n", "u.yaml").ok());
}

TEST(Dxf, ClosedPolylineLoopsBack) {
  StatusOr<DxfContents> d = parseDxf(dxf(lwpolyline("LOOP", {{0, 0}, {30, 0}, {30, 30}, {0, 30}}, 0, true)), "l.dxf");
  ASSERT_TRUE(d.ok());
  EXPECT_TRUE(d->polylines[0].closed);
  StatusOr<SurveyNetwork> net = dxfToSurvey(*d, {}, *parseSectionSpec("{shape: rectangle, width: 4, height: 3}"), 0.2);
  ASSERT_TRUE(net.ok()) << net.status().message();
  EXPECT_NEAR(net->totalLength(), 120, 1e-9);
}

TEST(Dxf, FacesBecomeAMesh) {
  StatusOr<DxfContents> d = parseDxf(dxf(face({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}) +
                                         face({{0, 0, 1}, {1, 0, 1}, {1, 1, 1}})),
                                     "f.dxf");
  ASSERT_TRUE(d.ok()) << d.status().message();
  EXPECT_TRUE(d->polylines.empty());
  EXPECT_EQ(d->faces.triangles.size(), 3u);  // a quad and a triangle
}

TEST(Dxf, EmptyAndBrokenFilesAreRefused) {
  EXPECT_FALSE(parseDxf("", "e.dxf").ok());
  StatusOr<DxfContents> none = parseDxf(dxf("0\nLINE\n8\n0\n10\n0\n20\n0\n11\n1\n21\n1\n"), "n.dxf");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("no LWPOLYLINE/POLYLINE"), std::string::npos);
  EXPECT_FALSE(parseDxf("AutoCAD Binary DXF\r\n\x1a", "b.dxf").ok());
  std::string lie = dxf(lwpolyline("M", {{0, 0}, {1, 0}}, 0));
  lie.replace(lie.find("90\n2\n"), 5, "90\n2000000000\n");
  StatusOr<DxfContents> liar = parseDxf(lie, "lie.dxf");
  ASSERT_FALSE(liar.ok());
  EXPECT_NE(liar.status().message().find("lie.dxf:10: LWPOLYLINE announces 2000000000 vertices"), std::string::npos)
      << liar.status().message();
  ReadLimits small;
  small.max_points = 2;
  EXPECT_FALSE(parseDxf(dxf(lwpolyline("M", {{0, 0}, {1, 0}, {2, 0}}, 0)), "big.dxf", small).ok());
  // Every prefix of a valid drawing: refused or read, never a crash or a hang.
  const std::string full = dxf(lwpolyline("MAIN", {{0, 0}, {40, 0}}, -1) + face({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}}));
  for (std::size_t n = 0; n < full.size(); n += 3) (void)parseDxf(full.substr(0, n), "cut.dxf");
}

}  // namespace
}  // namespace adit::map
