// SPDX-License-Identifier: BSD-3-Clause
// ROS map_server maps: the YAML fields, PGM (P5, P2) and PNG images written by the test, pixel
// classification as map_server does it (thresholds, negate, alpha), extrusion with origin and
// yaw, and malformed input refused with the file and line or offset.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "adit/map/readers/ros_map.hpp"

namespace adit::map {
namespace {

// 0 = black (occupied), 254 = white (free), 205 = grey (unknown), as map_saver writes them.
std::string pgm5(int w, int h, const std::vector<int>& px) {
  std::string s = "P5\n# test\n" + std::to_string(w) + " " + std::to_string(h) + "\n255\n";
  for (int v : px) s.push_back(char(v));
  return s;
}

std::uint32_t crc32(const std::string& d) {
  std::uint32_t c = 0xffffffffu;
  for (unsigned char b : d) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::string be32(std::uint32_t v) {
  return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}

// A PNG with 8-bit grey (colour type 0) or RGBA (6) pixels in stored (uncompressed) deflate blocks.
std::string png(int w, int h, int channels, const std::vector<int>& samples) {
  std::string raw;
  for (int r = 0; r < h; ++r) {
    raw.push_back('\0');  // filter: none
    for (int i = 0; i < w * channels; ++i) raw.push_back(char(samples[std::size_t(r * w * channels + i)]));
  }
  std::string z = "\x78\x01";
  for (std::size_t o = 0; o < raw.size() || o == 0; o += 65535) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - o);
    z.push_back(o + n >= raw.size() ? '\x01' : '\x00');
    z.push_back(char(n & 0xff));
    z.push_back(char(n >> 8));
    z.push_back(char(~n & 0xff));
    z.push_back(char((~n >> 8) & 0xff));
    z += raw.substr(o, n);
    if (o + n >= raw.size()) break;
  }
  std::uint32_t a = 1, b = 0;
  for (unsigned char ch : raw) {
    a = (a + ch) % 65521;
    b = (b + a) % 65521;
  }
  z += be32((b << 16) | a);
  auto chunk = [](const std::string& type, const std::string& data) {
    return be32(std::uint32_t(data.size())) + type + data + be32(crc32(type + data));
  };
  std::string ihdr = be32(std::uint32_t(w)) + be32(std::uint32_t(h));
  ihdr += std::string{char(8), char(channels == 4 ? 6 : 0), 0, 0, 0};
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", z) + chunk("IEND", "");
}

RosMap yamlOrFail(const std::string& text) {
  StatusOr<RosMap> m = parseRosMapYaml(text, "map.yaml");
  EXPECT_TRUE(m.ok()) << m.status().message();
  return m.ok() ? *m : RosMap{};
}

const char* kYaml = "image: map.pgm\nresolution: 0.5\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\n"
                    "occupied_thresh: 0.65\nfree_thresh: 0.196\n";

TEST(RosMap, PgmPixelsAreClassifiedLikeMapServer) {
  RosMap m = yamlOrFail(kYaml);
  ASSERT_TRUE(decodeRosMapImage(pgm5(3, 1, {0, 254, 205}), "map.pgm", &m).ok());
  EXPECT_EQ(m.cells, (std::vector<std::int8_t>{100, 0, -1}));
  RosMap n = yamlOrFail(std::string(kYaml) + "negate: 1\n");
  n.negate = true;
  ASSERT_TRUE(decodeRosMapImage(pgm5(3, 1, {0, 254, 205}), "map.pgm", &n).ok());
  EXPECT_EQ(n.cells, (std::vector<std::int8_t>{0, 100, 100}));  // 205/255 = 0.80 > 0.65
  // Ascii P2 with a 16-bit maxval scales to 0..255.
  RosMap a = yamlOrFail(kYaml);
  ASSERT_TRUE(decodeRosMapImage("P2\n2 1\n1000\n0 1000\n", "map.pgm", &a).ok());
  EXPECT_EQ(a.cells, (std::vector<std::int8_t>{100, 0}));
}

TEST(RosMap, PngGreyAndAlpha) {
  RosMap m = yamlOrFail(kYaml);
  Status s = decodeRosMapImage(png(3, 1, 1, {0, 254, 205}), "map.png", &m);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(m.cells, (std::vector<std::int8_t>{100, 0, -1}));
  RosMap r = yamlOrFail(kYaml);
  s = decodeRosMapImage(png(2, 1, 4, {255, 255, 255, 255, 255, 255, 255, 0}), "map.png", &r);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(r.cells, (std::vector<std::int8_t>{0, -1}));  // transparent = unknown
}

TEST(RosMap, ExtrusionPlacesCellsWithOriginAndYaw) {
  RosMap m = yamlOrFail(kYaml);
  // 2 x 2 image: top row (north) occupied | free; bottom row free | unknown.
  ASSERT_TRUE(decodeRosMapImage(pgm5(2, 2, {0, 254, 254, 205}), "map.pgm", &m).ok());
  ExtrudeOptions o;
  o.height_m = 1.0;
  StatusOr<OccupancyMap> map = extrudeRosMap(m, o);
  ASSERT_TRUE(map.ok()) << map.status().message();
  // Origin (-1, 2) is the lower-left corner; pixels are 0.5 m.
  EXPECT_EQ(map->state({-0.75, 2.75, 0.5}), VoxelState::kOccupied);  // top-left
  EXPECT_EQ(map->state({-0.25, 2.75, 0.5}), VoxelState::kFree);      // top-right
  EXPECT_EQ(map->state({-0.75, 2.25, 0.9}), VoxelState::kFree);      // bottom-left
  EXPECT_EQ(map->state({-0.25, 2.25, 0.5}), VoxelState::kUnknown);   // bottom-right
  EXPECT_EQ(map->state({-0.75, 2.25, 1.2}), VoxelState::kUnknown);   // above the extrusion
  // Yaw 90 degrees turns the image about the origin: +x of the image points north.
  m.origin_yaw = M_PI / 2;
  map = extrudeRosMap(m, o);
  ASSERT_TRUE(map.ok());
  EXPECT_EQ(map->state({-1.75, 2.25, 0.5}), VoxelState::kOccupied);
  // Finer voxels than pixels sub-sample each pixel.
  m.origin_yaw = 0;
  o.resolution_m = 0.1;
  map = extrudeRosMap(m, o);
  ASSERT_TRUE(map.ok());
  EXPECT_EQ(map->state({-0.95, 2.95, 0.05}), VoxelState::kOccupied);
  EXPECT_EQ(map->stats().free_voxels, 2u * 25u * 10u);
}

TEST(RosMap, BadYamlIsNamed) {
  auto err = [](const std::string& text) {
    StatusOr<RosMap> m = parseRosMapYaml(text, "bad.yaml");
    return m.ok() ? std::string("ok") : m.status().message();
  };
  EXPECT_NE(err("resolution: 0.1\norigin: [0, 0, 0]\n").find("missing field 'image'"), std::string::npos);
  EXPECT_NE(err("image: a.pgm\norigin: [0, 0, 0]\n").find("missing field 'resolution'"), std::string::npos);
  EXPECT_NE(err("image: a.pgm\nresolution: -1\norigin: [0, 0, 0]\n").find("bad.yaml:2:"), std::string::npos);
  EXPECT_NE(err("image: a.pgm\nresolution: 0.1\norigin: [0, 0]\n").find("origin"), std::string::npos);
  EXPECT_NE(err("image: a.pgm\nresolution: 0.1\norigin: [0, .nan, 0]\n").find("bad.yaml:3:"), std::string::npos);
  EXPECT_NE(err("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nfree_thresh: 0.9\n").find("free_thresh"),
            std::string::npos);
  EXPECT_NE(err("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: raw\n").find("bad.yaml:4:"), std::string::npos);
  EXPECT_NE(err("image: [unclosed\n").find("YAML error"), std::string::npos);
  EXPECT_TRUE(isRosMapYaml(kYaml));
  EXPECT_FALSE(isRosMapYaml("stations: {}\n"));
}

TEST(RosMap, BadImagesAreRefused) {
  RosMap m = yamlOrFail(kYaml);
  auto err = [&](const std::string& bytes, std::uint64_t max = 400'000'000) {
    Status s = decodeRosMapImage(bytes, "img", &m, max);
    return s.ok() ? std::string("ok") : s.message();
  };
  EXPECT_NE(err("").find("not a PGM"), std::string::npos);
  EXPECT_NE(err("GIF89a").find("img: offset 0"), std::string::npos);
  EXPECT_NE(err(pgm5(4, 4, {0, 0, 0})).find("truncated PGM"), std::string::npos);
  EXPECT_NE(err("P5\n99999 99999\n255\n").find("exceeds the limit"), std::string::npos);
  EXPECT_NE(err("P5\n0 3\n255\n").find("must be positive"), std::string::npos);
  EXPECT_NE(err("P2\n2 1\n255\n0\n").find("pixel 2 missing"), std::string::npos);
  EXPECT_NE(err("P2\n2 1\n100\n0 101\n").find("above maxval"), std::string::npos);
  std::string big = png(3, 1, 1, {0, 0, 0});
  big.replace(16, 4, be32(100000));
  big.replace(20, 4, be32(100000));
  EXPECT_NE(err(big).find("img: offset 16"), std::string::npos);
  std::string broken = png(3, 1, 1, {0, 0, 0});
  broken[40] ^= 0x55;
  EXPECT_NE(err(broken), "ok");
  EXPECT_NE(err(png(3, 1, 1, {0, 0, 0}).substr(0, 30)), "ok");
  // Every prefix of a valid PGM: refused or decoded, never a crash.
  const std::string full = pgm5(5, 4, std::vector<int>(20, 254));
  for (std::size_t n = 0; n < full.size(); ++n) (void)err(full.substr(0, n));
}

TEST(RosMap, HugeExtrusionIsEstimatedFirst) {
  RosMap m = yamlOrFail(kYaml);
  ASSERT_TRUE(decodeRosMapImage(pgm5(2, 2, {254, 254, 254, 254}), "map.pgm", &m).ok());
  ExtrudeOptions o;
  o.height_m = 1000;
  o.resolution_m = 0.01;
  StatusOr<OccupancyMap> map = extrudeRosMap(m, o);
  ASSERT_FALSE(map.ok());
  EXPECT_NE(map.status().message().find("needs about"), std::string::npos) << map.status().message();
}

}  // namespace
}  // namespace adit::map
