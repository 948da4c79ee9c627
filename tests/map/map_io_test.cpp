// SPDX-License-Identifier: BSD-3-Clause
// Reader/writer tests: OctoMap .bt/.ot round trips, every kind of malformed file, empty maps,
// atomic writes, survey files through loadMap, and (when the shared data is present) the real
// Freiburg building map. The rule under test: bad input gets a clear error naming the file and
// what is wrong; never a crash, hang, huge allocation or a partially written output.
#include "adit/map/map_io.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "adit/map/survey_network.hpp"
#include "support/survey_example.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Time limits are for optimized builds; Debug and sanitizer builds get ten times as long (and the
// random trials are fewer there).
#if defined(NDEBUG) && !defined(__SANITIZE_ADDRESS__)
constexpr double kSlowdown = 1.0;
#else
constexpr double kSlowdown = 10.0;
#endif
constexpr bool kOptimized = kSlowdown == 1.0;

// ---------------------------------------------------------------------------------------------
// Helpers

/// A fresh directory per test, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string tag = info ? std::string(info->test_suite_name()) + "." + info->name() : "io";
    for (char& c : tag)
      if (c == '/') c = '_';
    dir_ = fs::path(::testing::TempDir()) /
           ("adit_map_io_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" + tag);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~ScratchDir() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  const fs::path& dir() const { return dir_; }
  /// Names of the entries in the directory (to catch stray temporary files).
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

 private:
  fs::path dir_;
};

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

/// Offset of the first byte after the header's "data" line.
std::size_t dataOffset(const std::string& bytes) {
  const std::size_t at = bytes.find("\ndata\n");
  EXPECT_NE(at, std::string::npos);
  return at == std::string::npos ? 0 : at + 6;
}

/// Replaces the value of header field `key` ("size", "res", "id").
std::string withHeaderField(const std::string& bytes, const std::string& key, const std::string& value) {
  const std::string needle = "\n" + key + " ";
  const std::size_t at = bytes.find(needle);
  EXPECT_NE(at, std::string::npos) << key;
  if (at == std::string::npos) return bytes;
  const std::size_t begin = at + needle.size();
  const std::size_t end = bytes.find('\n', begin);
  return bytes.substr(0, begin) + value + bytes.substr(end);
}

std::string withoutHeaderLine(const std::string& bytes, const std::string& key) {
  const std::size_t at = bytes.find("\n" + key);
  EXPECT_NE(at, std::string::npos) << key;
  if (at == std::string::npos) return bytes;
  const std::size_t end = bytes.find('\n', at + 1);
  return bytes.substr(0, at) + bytes.substr(end);
}

std::string btHeader(std::uint64_t size, const std::string& res = "0.25", const std::string& id = "OcTree") {
  return "# Octomap OcTree binary file\n# crafted by map_io_test\nid " + id + "\nsize " + std::to_string(size) +
         "\nres " + res + "\ndata\n";
}
std::string otHeader(std::uint64_t size, const std::string& res = "0.25", const std::string& id = "OcTree") {
  return "# Octomap OcTree file\n# crafted by map_io_test\nid " + id + "\nsize " + std::to_string(size) + "\nres " +
         res + "\ndata\n";
}

/// One .ot node record: log-odds then the child mask.
std::string otNode(float log_odds, unsigned char mask) {
  std::string rec(5, '\0');
  std::memcpy(rec.data(), &log_odds, sizeof(float));
  rec[4] = char(mask);
  return rec;
}

/// Binary record codes per child (OctoMap 1.9.7 OccupancyOcTreeBase::writeBinaryNode: the low
/// bit of each pair set alone is a free leaf, the high bit alone an occupied leaf, both an
/// inner node).
constexpr unsigned kBtFree = 1, kBtOccupied = 2, kBtInner = 3;
std::string btRecord(unsigned child0_code, unsigned other_children_code = 0) {
  unsigned bits = child0_code;
  for (int i = 1; i < 8; ++i) bits |= other_children_code << (2 * i);
  return std::string{char(bits & 0xFF), char((bits >> 8) & 0xFF)};
}

::testing::AssertionResult failsWith(const StatusOr<OccupancyMap>& result, StatusCode code, const std::string& name,
                                     const std::string& what = "") {
  if (result.ok()) return ::testing::AssertionFailure() << "loaded, expected " << statusCodeName(code);
  const Status& s = result.status();
  if (s.code() != code)
    return ::testing::AssertionFailure() << "code " << statusCodeName(s.code()) << ", expected "
                                         << statusCodeName(code) << ": " << s.message();
  if (s.message().find(name) == std::string::npos)
    return ::testing::AssertionFailure() << "message does not name '" << name << "': " << s.message();
  if (!what.empty() && s.message().find(what) == std::string::npos)
    return ::testing::AssertionFailure() << "message does not say '" << what << "': " << s.message();
  return ::testing::AssertionSuccess() << s.message();
}

/// The voxelized junction network and its serialized forms, built once.
struct Fixture {
  std::unique_ptr<OccupancyMap> map;
  std::string bt, ot;
};
const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture fx;
    fx.map = std::make_unique<OccupancyMap>(test::voxelizeOrFail(test::junctionNetwork(0.25)));
    ScratchDir dir;
    const Status a = writeOctomap(*fx.map, dir.path("junction.bt"));
    const Status b = writeOctomap(*fx.map, dir.path("junction.ot"));
    EXPECT_TRUE(a.ok()) << a.toString();
    EXPECT_TRUE(b.ok()) << b.toString();
    fx.bt = readBytes(dir.path("junction.bt"));
    fx.ot = readBytes(dir.path("junction.ot"));
    return fx;
  }();
  return f;
}

struct FormatCase {
  const char* ext;   // ".bt" / ".ot"
  const std::string& (*bytes)();
};
const std::string& btBytes() { return fixture().bt; }
const std::string& otBytes() { return fixture().ot; }
const FormatCase kFormats[] = {{".bt", &btBytes}, {".ot", &otBytes}};

void expectSameMap(const OccupancyMap& a, const OccupancyMap& b, std::uint64_t seed) {
  EXPECT_EQ(a.resolution(), b.resolution());
  EXPECT_EQ(a.stats().free_voxels, b.stats().free_voxels);
  EXPECT_EQ(a.stats().occupied_voxels, b.stats().occupied_voxels);
  EXPECT_EQ(a.stats().unknown_voxels, b.stats().unknown_voxels);
  EXPECT_EQ(a.stats().octree_nodes, b.stats().octree_nodes);
  EXPECT_TRUE(a.bounds().min.isApprox(b.bounds().min, 1e-9)) << a.bounds().min.transpose() << " vs "
                                                             << b.bounds().min.transpose();
  EXPECT_TRUE(a.bounds().max.isApprox(b.bounds().max, 1e-9)) << a.bounds().max.transpose() << " vs "
                                                             << b.bounds().max.transpose();
  std::mt19937_64 rng(seed);
  const Aabb box = a.bounds().inflated(1.0);
  int mismatches = 0, free_seen = 0, occupied_seen = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vec3 p = test::randomPoint(rng, box);
    const VoxelState sa = a.state(p), sb = b.state(p);
    if (sa != sb && ++mismatches <= 5) ADD_FAILURE() << "state differs at " << p.transpose();
    free_seen += sa == VoxelState::kFree;
    occupied_seen += sa == VoxelState::kOccupied;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(free_seen, 0);  // the sample actually exercised both states
  EXPECT_GT(occupied_seen, 0);
}

/// Runs `fn`; if it has not returned after `seconds`, the process is aborted with a message (a
/// hang must fail the run, not stall it).
template <class Fn>
void withDeadline(double seconds, const char* what, Fn fn) {
  std::packaged_task<void()> task(fn);
  std::future<void> done = task.get_future();
  std::thread worker(std::move(task));
  if (done.wait_for(std::chrono::duration<double>(seconds)) != std::future_status::ready) {
    std::fprintf(stderr, "map_io_test: '%s' did not finish within %.0f s (hang)\n", what, seconds);
    std::abort();
  }
  worker.join();
  done.get();
}

// ---------------------------------------------------------------------------------------------
// 1. Round trips

TEST(MapIoRoundTrip, BinaryAndFullOctomapKeepResolutionStatsAndStates) {
  const OccupancyMap& original = *fixture().map;
  ScratchDir dir;
  std::uint64_t seed = 7;
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.ext);
    const std::string path = dir.path(std::string("roundtrip") + f.ext);
    ASSERT_TRUE(writeOctomap(original, path).ok());
    StatusOr<OccupancyMap> loaded = loadMap(path);
    ASSERT_TRUE(loaded.ok()) << loaded.status().toString();
    EXPECT_EQ(loaded->unknownPolicy(), UnknownPolicy::kRock);
    expectSameMap(original, *loaded, seed++);
    // Writing the loaded map again gives the same bytes: nothing drifts over repeated round trips.
    const std::string again = dir.path(std::string("again") + f.ext);
    ASSERT_TRUE(writeOctomap(*loaded, again).ok());
    EXPECT_EQ(readBytes(path), readBytes(again));
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"again.bt", "again.ot", "roundtrip.bt", "roundtrip.ot"}));
}

TEST(MapIoRoundTrip, LoadOptionsPolicyIsApplied) {
  ScratchDir dir;
  const std::string path = dir.path("policy.bt");
  writeBytes(path, fixture().bt);
  LoadOptions o;
  o.unknown_policy = UnknownPolicy::kFree;
  StatusOr<OccupancyMap> loaded = loadMap(path, o);
  ASSERT_TRUE(loaded.ok()) << loaded.status().toString();
  EXPECT_EQ(loaded->unknownPolicy(), UnknownPolicy::kFree);
}

TEST(MapIoRoundTrip, ResolutionKeepsFullPrecision) {
  // OctoMap's own writers print the resolution with 6 significant digits; a map at 0.1234567891 m
  // must come back at exactly that resolution, or every voxel key shifts.
  const double res = 0.1234567891;
  auto tree = std::make_shared<octomap::OcTree>(res);
  // A small duct: free core, occupied walls, far from the origin so that key shifts show.
  for (int i = 0; i < 40; ++i)
    for (int j = -3; j <= 3; ++j)
      for (int k = -3; k <= 3; ++k)
        tree->updateNode(octomap::point3d(float(100.0 + res * i), float(3.0 + res * j), float(1.0 + res * k)),
                         std::abs(j) > 1 || std::abs(k) > 1);
  StatusOr<OccupancyMap> map = OccupancyMap::create(tree);
  ASSERT_TRUE(map.ok()) << map.status().toString();
  ScratchDir dir;
  std::uint64_t seed = 11;
  for (const FormatCase& f : kFormats) {
    SCOPED_TRACE(f.ext);
    const std::string path = dir.path(std::string("precise") + f.ext);
    ASSERT_TRUE(writeOctomap(*map, path).ok());
    StatusOr<OccupancyMap> loaded = loadMap(path);
    ASSERT_TRUE(loaded.ok()) << loaded.status().toString();
    EXPECT_EQ(loaded->resolution(), res);
    expectSameMap(*map, *loaded, seed++);
  }
}

TEST(MapIoRoundTrip, FormatFromPathIsCaseInsensitive) {
  EXPECT_EQ(*formatFromPath("a/b.BT"), MapFormat::kOctomapBinary);
  EXPECT_EQ(*formatFromPath("b.Ot"), MapFormat::kOctomapFull);
  EXPECT_EQ(*formatFromPath("c.yml"), MapFormat::kSurveyYaml);
  EXPECT_EQ(*formatFromPath("c.YAML"), MapFormat::kSurveyYaml);
  for (const char* bad : {"map.pcd", "map", "map.bt.bak", "map.", "dir.bt/"}) {
    StatusOr<MapFormat> f = formatFromPath(bad);
    ASSERT_FALSE(f.ok()) << bad;
    EXPECT_EQ(f.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(f.status().message().find("unknown map format"), std::string::npos) << f.status().message();
  }
}

TEST(MapIoRoundTrip, OctomapsOwnReaderReadsOurFiles) {
  // Interoperability: the files adit writes are ordinary OctoMap files.
  ScratchDir dir;
  const std::string bt = dir.path("interop.bt");
  ASSERT_TRUE(writeOctomap(*fixture().map, bt).ok());
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(bt));
  EXPECT_EQ(tree.getResolution(), fixture().map->resolution());
  EXPECT_EQ(tree.size(), fixture().map->stats().octree_nodes);
  const std::string ot = dir.path("interop.ot");
  ASSERT_TRUE(writeOctomap(*fixture().map, ot).ok());
  std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(ot));
  ASSERT_NE(abstract, nullptr);
  EXPECT_EQ(abstract->getTreeType(), "OcTree");
  EXPECT_EQ(abstract->size(), fixture().map->stats().octree_nodes);
  // At an ordinary resolution the bytes are exactly what OctoMap's own writers produce.
  std::ostringstream bt_ref, ot_ref;
  ASSERT_TRUE(fixture().map->octree().writeBinaryConst(bt_ref));
  ASSERT_TRUE(fixture().map->octree().write(ot_ref));
  EXPECT_EQ(readBytes(bt), bt_ref.str());
  EXPECT_EQ(readBytes(ot), ot_ref.str());
}

// ---------------------------------------------------------------------------------------------
// 2. Malformed OctoMap files

TEST(MapIoMalformed, HeaderProblemsAreNamed) {
  ScratchDir dir;
  for (const FormatCase& f : kFormats) {
    const std::string& good = f.bytes();
    const std::size_t data = dataOffset(good);
    const std::string magic = good.substr(0, good.find('\n'));
    struct Case {
      const char* what;
      std::string bytes;
      StatusCode code;
      const char* expect;
    };
    const std::vector<Case> cases = {
        {"empty file", "", StatusCode::kDataLoss, "empty"},
        {"wrong magic", "# Octomap ColorOcTree file\n" + good.substr(good.find('\n') + 1), StatusCode::kInvalidArgument,
         "not an OctoMap file"},
        {"a PCD file", "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n", StatusCode::kInvalidArgument,
         "not an OctoMap file"},
        {"binary junk", std::string("\x89PNG\r\n\x1a\n\0\0\0", 11), StatusCode::kInvalidArgument, "not an OctoMap file"},
        {"magic only, no newline", magic, StatusCode::kInvalidArgument, "not an OctoMap file"},
        {"header without data", good.substr(0, data - 5), StatusCode::kDataLoss, "no 'data' line"},
        {"header cut before data", good.substr(0, good.find("\nres ") + 1), StatusCode::kDataLoss, "no 'data' line"},
        {"missing res", withoutHeaderLine(good, "res"), StatusCode::kInvalidArgument, "no 'res'"},
        {"missing size", withoutHeaderLine(good, "size"), StatusCode::kInvalidArgument, "no 'size'"},
        {"res 0", withHeaderField(good, "res", "0"), StatusCode::kInvalidArgument, "res"},
        {"res -1", withHeaderField(good, "res", "-1"), StatusCode::kInvalidArgument, "res"},
        {"res nan", withHeaderField(good, "res", "nan"), StatusCode::kInvalidArgument, "res"},
        {"res inf", withHeaderField(good, "res", "inf"), StatusCode::kInvalidArgument, "res"},
        {"res text", withHeaderField(good, "res", "fine"), StatusCode::kInvalidArgument, "res"},
        {"res 1e-5", withHeaderField(good, "res", "1e-5"), StatusCode::kInvalidArgument, "res"},
        {"res 1e300", withHeaderField(good, "res", "1e300"), StatusCode::kInvalidArgument, "res"},
        {"res 0.25 m", withHeaderField(good, "res", "0.25 m"), StatusCode::kInvalidArgument, "res"},
        {"size -5", withHeaderField(good, "size", "-5"), StatusCode::kInvalidArgument, "size"},
        {"size text", withHeaderField(good, "size", "many"), StatusCode::kInvalidArgument, "size"},
        {"size 1e300", withHeaderField(good, "size", "1e300"), StatusCode::kInvalidArgument, "size"},
        {"size 12.5", withHeaderField(good, "size", "12.5"), StatusCode::kInvalidArgument, "size"},
        {"ColorOcTree", withHeaderField(good, "id", "ColorOcTree"), StatusCode::kInvalidArgument, "ColorOcTree"},
        {"OcTreeStamped", withHeaderField(good, "id", "OcTreeStamped"), StatusCode::kInvalidArgument, "not supported"},
        {"empty id", withHeaderField(good, "id", ""), StatusCode::kInvalidArgument, "id"},
        {"unknown field", withHeaderField(good, "id", "OcTree\ncolour red"), StatusCode::kInvalidArgument,
         "unknown header field 'colour'"},
        {"endless header", magic + "\n" + std::string(100000, '\n'), StatusCode::kDataLoss, "no 'data' line"},
        {"endless header line", magic + "\n" + std::string(100000, '#'), StatusCode::kDataLoss, "no 'data' line"},
    };
    for (const Case& c : cases) {
      SCOPED_TRACE(std::string(f.ext) + ": " + c.what);
      const std::string path = dir.path("bad" + std::string(f.ext));
      writeBytes(path, c.bytes);
      EXPECT_TRUE(failsWith(loadMap(path), c.code, path, c.expect));
    }
  }
}

TEST(MapIoMalformed, SizeDisagreeingWithTheTree) {
  ScratchDir dir;
  for (const FormatCase& f : kFormats) {
    const std::string& good = f.bytes();
    const std::uint64_t n = fixture().map->stats().octree_nodes;
    const std::string path = dir.path("size" + std::string(f.ext));
    for (std::uint64_t claimed : {n - 1, n + 1, n / 2, 2 * n, std::uint64_t{1}, std::uint64_t{999999999999},
                                  std::uint64_t{999999999999999}}) {
      SCOPED_TRACE(std::string(f.ext) + " size " + std::to_string(claimed));
      writeBytes(path, withHeaderField(good, "size", std::to_string(claimed)));
      const auto t0 = Clock::now();
      EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path));
      EXPECT_LT(secondsSince(t0), 5.0 * kSlowdown);  // a hang guard, not a speed test
    }
    // A huge size with a tiny body must not allocate for the claimed size.
    const std::string tiny = f.ext == std::string(".bt") ? btHeader(999999999999) + btRecord(kBtFree)
                                                         : otHeader(999999999999) + otNode(-2.0f, 0);
    writeBytes(path, tiny);
    EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path)) << f.ext;
  }
}

TEST(MapIoMalformed, TruncatedAtManyCutPoints) {
  const auto t0 = Clock::now();
  for (const FormatCase& f : kFormats) {
    const std::string& good = f.bytes();
    const std::size_t data = dataOffset(good);
    const std::string name = std::string("cut") + f.ext;
    // About 400 cut points over the data section, plus every byte of the first and last 64.
    std::vector<std::size_t> cuts;
    const std::size_t step = std::max<std::size_t>(1, (good.size() - data) / 400);
    for (std::size_t c = data; c < good.size(); c += step) cuts.push_back(c);
    for (std::size_t k = 0; k < 64; ++k) {
      cuts.push_back(data + k);
      cuts.push_back(good.size() - 1 - k);
    }
    for (std::size_t c : cuts) {
      StatusOr<OccupancyMap> m = parseOctomap(good.substr(0, c), name);
      ASSERT_TRUE(failsWith(m, StatusCode::kDataLoss, name)) << f.ext << " cut at " << c << " of " << good.size();
    }
    // Cuts inside the header fail too (with whatever the missing part is), naming the file.
    for (std::size_t c = 0; c < data; ++c) {
      StatusOr<OccupancyMap> m = parseOctomap(good.substr(0, c), name);
      ASSERT_FALSE(m.ok()) << c;
      ASSERT_NE(m.status().message().find(name), std::string::npos) << m.status().message();
    }
  }
  EXPECT_LT(secondsSince(t0), 5.0 * kSlowdown);
}

TEST(MapIoMalformed, TruncatedFileOnDisk) {
  ScratchDir dir;
  for (const FormatCase& f : kFormats) {
    const std::string& good = f.bytes();
    const std::string path = dir.path(std::string("truncated") + f.ext);
    writeBytes(path, good.substr(0, dataOffset(good) + (good.size() - dataOffset(good)) / 2));
    EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "truncated")) << f.ext;
  }
}

TEST(MapIoMalformed, RandomByteFlipsLoadConsistentlyOrFailCleanly) {
  int loaded = 0, failed = 0;
  withDeadline(30.0 * kSlowdown, "random byte flips", [&] {
    const auto t0 = Clock::now();
    std::mt19937_64 rng(20240611);
    for (const FormatCase& f : kFormats) {
      const std::string& good = f.bytes();
      const std::size_t data = dataOffset(good);
      const std::string name = std::string("flipped") + f.ext;
      for (int trial = 0; trial < (kOptimized ? 400 : 120); ++trial) {
        std::string bytes = good;
        // Mostly the data section; one trial in eight hits the header.
        const bool header = trial % 8 == 0;
        std::uniform_int_distribution<std::size_t> where(header ? 0 : data, (header ? data : bytes.size()) - 1);
        const int flips = 1 + int(rng() % 4);
        for (int k = 0; k < flips; ++k) bytes[where(rng)] ^= char(1u << (rng() % 8));
        StatusOr<OccupancyMap> m = parseOctomap(bytes, name);
        if (m.ok()) {
          ++loaded;
          // A map that loads is a consistent map: stats add up and queries work.
          const MapStats& s = m->stats();
          EXPECT_GT(s.free_voxels, 0u);
          EXPECT_GT(s.octree_nodes, 0u);
          EXPECT_TRUE(std::isfinite(s.resolution_m) && s.resolution_m > 0);
          std::uint64_t leaves = 0;
          m->forEachLeaf([&](const Vec3& c, double size, VoxelState) {
            ++leaves;
            EXPECT_TRUE(allFinite(c) && size > 0);
          });
          EXPECT_LE(leaves, s.octree_nodes);
          std::mt19937_64 q(trial);
          for (int i = 0; i < 50; ++i) (void)m->isFree(test::randomPoint(q, m->bounds().inflated(1.0)));
        } else {
          ++failed;
          const Status& s = m.status();
          EXPECT_TRUE(s.code() == StatusCode::kDataLoss || s.code() == StatusCode::kInvalidArgument ||
                      s.code() == StatusCode::kFailedPrecondition)
              << s.toString();
          EXPECT_EQ(s.message().rfind(name, 0), 0u) << s.message();
        }
      }
    }
    EXPECT_LT(secondsSince(t0), 10.0 * kSlowdown);
  });
  std::printf("[          ] random flips: %d loaded, %d refused\n", loaded, failed);
  EXPECT_GT(failed, 0);
}

TEST(MapIoMalformed, BinaryNodeStreamDeeperThan16Levels) {
  ScratchDir dir;
  const std::string path = dir.path("deep.bt");
  // Every child "inner", over and over: the walk reaches depth 17 after 16 records.
  writeBytes(path, btHeader(999999) + std::string(64, '\xFF'));
  EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "deeper than 16 levels"));

  // A single chain: records at depth 0..levels-1, child 0 inner, the last one a free leaf.
  auto chain = [](int levels) {
    std::string bytes;
    for (int d = 0; d < levels; ++d) bytes += btRecord(d + 1 < levels ? kBtInner : kBtFree);
    return btHeader(std::uint64_t(levels) + 1) + bytes;
  };
  // Control: a leaf at depth 16 (one finest voxel) is legal and loads.
  writeBytes(path, chain(16));
  StatusOr<OccupancyMap> ok = loadMap(path);
  ASSERT_TRUE(ok.ok()) << ok.status().toString();
  EXPECT_EQ(ok->stats().free_voxels, 1u);
  for (int levels : {17, 18, 40}) {
    writeBytes(path, chain(levels));
    EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "deeper than 16 levels")) << levels;
  }
}

TEST(MapIoMalformed, FullNodeStreamDeeperThan16Levels) {
  ScratchDir dir;
  const std::string path = dir.path("deep.ot");
  auto chain = [](int levels) {  // `levels` inner nodes, then a leaf at depth `levels`
    std::string bytes;
    for (int d = 0; d < levels; ++d) bytes += otNode(-2.0f, 0x01);
    bytes += otNode(-2.0f, 0);
    return otHeader(std::uint64_t(levels) + 1) + bytes;
  };
  writeBytes(path, chain(16));
  StatusOr<OccupancyMap> ok = loadMap(path);
  ASSERT_TRUE(ok.ok()) << ok.status().toString();
  EXPECT_EQ(ok->stats().free_voxels, 1u);
  for (int levels : {17, 30}) {
    writeBytes(path, chain(levels));
    EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "deeper than 16 levels")) << levels;
  }
  // All eight children everywhere.
  std::string all;
  for (int i = 0; i < 200; ++i) all += otNode(0.0f, 0xFF);
  writeBytes(path, otHeader(200) + all);
  EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path));
}

TEST(MapIoMalformed, BinaryInnerNodeWithoutChildren) {
  // OctoMap never writes an "inner" code for a childless node; its reader would turn it into a
  // leaf with log-odds -FLT_MAX. Refuse it as corrupt.
  ScratchDir dir;
  const std::string path = dir.path("hollow.bt");
  // Root: child 0 inner (2 nodes so far); child 0's record has no children.
  writeBytes(path, btHeader(2) + btRecord(kBtInner) + btRecord(0));
  EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "has none"));
  // A free sibling (child 4, low bit of the second byte) does not make it valid either.
  writeBytes(path, btHeader(3) + btRecord(kBtInner).substr(0, 1) + char(kBtFree) + btRecord(0));
  EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "has none"));
  // Control: the same tree with a free leaf under the inner child loads.
  writeBytes(path, btHeader(4) + btRecord(kBtInner).substr(0, 1) + char(kBtFree) + btRecord(kBtFree));
  EXPECT_TRUE(loadMap(path).ok());
}

TEST(MapIoMalformed, TrailingGarbage) {
  ScratchDir dir;
  for (const FormatCase& f : kFormats) {
    const std::string path = dir.path(std::string("trailing") + f.ext);
    for (const std::string& tail : {std::string(1, '\0'), std::string("\n"), std::string(1000, 'x')}) {
      writeBytes(path, f.bytes() + tail);
      EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "unexpected bytes after the tree"))
          << f.ext << " +" << tail.size();
    }
  }
}

TEST(MapIoMalformed, NonFiniteLogOddsInFullFormat) {
  ScratchDir dir;
  const std::string path = dir.path("nan.ot");
  const std::string& good = fixture().ot;
  const std::size_t data = dataOffset(good);
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    // The root's value, and a node deep inside.
    for (std::size_t at : {data, data + 5 * 40}) {
      std::string bytes = good;
      std::memcpy(bytes.data() + at, &bad, sizeof(float));
      writeBytes(path, bytes);
      EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kDataLoss, path, "non-finite log-odds")) << bad << " @" << at;
    }
  }
  // Control: a finite log-odds in the same place is fine.
  std::string bytes = good;
  const float finite = 1.5f;
  std::memcpy(bytes.data() + data, &finite, sizeof(float));
  writeBytes(path, bytes);
  EXPECT_TRUE(loadMap(path).ok());
}

TEST(MapIoMalformed, NotAFile) {
  ScratchDir dir;
  // A directory with a map's name.
  const std::string d = dir.path("district.bt");
  fs::create_directory(d);
  EXPECT_TRUE(failsWith(loadMap(d), StatusCode::kInvalidArgument, d, "directory"));
  const std::string y = dir.path("district.yaml");
  fs::create_directory(y);
  EXPECT_TRUE(failsWith(loadMap(y), StatusCode::kInvalidArgument, y, "directory"));
  // Missing files.
  for (const char* name : {"missing.bt", "missing.ot", "missing.yaml"}) {
    const std::string p = dir.path(name);
    EXPECT_TRUE(failsWith(loadMap(p), StatusCode::kNotFound, p, "no such file"));
  }
  const std::string deep = dir.path("no/such/dir/map.bt");
  EXPECT_TRUE(failsWith(loadMap(deep), StatusCode::kNotFound, deep));
  // Unknown extension, even when the content is a valid OctoMap.
  const std::string pcd = dir.path("cloud.pcd");
  writeBytes(pcd, fixture().bt);
  EXPECT_TRUE(failsWith(loadMap(pcd), StatusCode::kInvalidArgument, pcd, "unknown map format"));
  // A device: not a regular file.
  const std::string dev = dir.path("null.bt");
  fs::create_symlink("/dev/null", dev);
  EXPECT_TRUE(failsWith(loadMap(dev), StatusCode::kInvalidArgument, dev, "not a regular file"));
  // A dangling symlink is a missing file.
  const std::string dangling = dir.path("dangling.ot");
  fs::create_symlink(dir.path("nowhere.ot"), dangling);
  EXPECT_TRUE(failsWith(loadMap(dangling), StatusCode::kNotFound, dangling));
  // A symlink to a good map loads.
  writeBytes(dir.path("real.bt"), fixture().bt);
  fs::create_symlink(dir.path("real.bt"), dir.path("link.bt"));
  EXPECT_TRUE(loadMap(dir.path("link.bt")).ok());
}

TEST(MapIoMalformed, FifoDoesNotHang) {
  // Opening a FIFO for reading blocks until someone writes: the reader must refuse it up front.
  ScratchDir dir;
  const std::string fifo = dir.path("pipe.bt");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  auto result = std::async(std::launch::async, [&] { return loadMap(fifo); });
  if (result.wait_for(std::chrono::seconds(3)) != std::future_status::ready) {
    // Unblock the reader (it is stuck in open()) so that the test fails instead of hanging.
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
    ADD_FAILURE() << "loadMap on a FIFO blocked";
  }
  StatusOr<OccupancyMap> m = result.get();
  EXPECT_TRUE(failsWith(m, StatusCode::kInvalidArgument, fifo, "not a regular file"));
}

TEST(MapIoMalformed, ReadFileSizeLimit) {
  ScratchDir dir;
  const std::string path = dir.path("big.bt");
  writeBytes(path, fixture().bt);
  StatusOr<std::string> bytes = readFile(path, 100);
  ASSERT_FALSE(bytes.ok());
  EXPECT_EQ(bytes.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bytes.status().message().find(path), std::string::npos) << bytes.status().message();
  EXPECT_NE(bytes.status().message().find("above the limit"), std::string::npos) << bytes.status().message();
  bytes = readFile(path);
  ASSERT_TRUE(bytes.ok()) << bytes.status().toString();
  EXPECT_EQ(*bytes, fixture().bt);
}

TEST(MapIoMalformed, ParseOctomapFromBytesNamesTheSource) {
  EXPECT_TRUE(failsWith(parseOctomap("", "memory:buffer"), StatusCode::kDataLoss, "memory:buffer"));
  StatusOr<OccupancyMap> m = parseOctomap(fixture().bt, "memory:buffer");
  ASSERT_TRUE(m.ok()) << m.status().toString();
  EXPECT_EQ(m->stats().free_voxels, fixture().map->stats().free_voxels);
}

// ---------------------------------------------------------------------------------------------
// 3. Empty maps

TEST(MapIoEmpty, ZeroNodesOrOnlyOccupiedIsAnEmptyMap) {
  ScratchDir dir;
  // Written by OctoMap itself: an empty tree, and a tree with occupied voxels only.
  octomap::OcTree empty(0.2);
  octomap::OcTree rock(0.2);
  for (int i = 0; i < 20; ++i) rock.updateNode(octomap::point3d(float(i) * 0.2f, 0.0f, 0.0f), true);
  std::vector<std::pair<std::string, std::string>> files;
  {
    std::ostringstream a, b, c, d;
    empty.writeBinaryConst(a);
    empty.write(b);
    rock.writeBinaryConst(c);
    rock.write(d);
    files = {{"empty.bt", a.str()}, {"empty.ot", b.str()}, {"rock.bt", c.str()}, {"rock.ot", d.str()}};
  }
  // Crafted: size 0 with no data; a root-only tree (OctoMap reads a childless root as occupied).
  files.push_back({"size0.bt", btHeader(0)});
  files.push_back({"size0.ot", otHeader(0)});
  files.push_back({"root.bt", btHeader(1) + btRecord(0)});
  files.push_back({"root.ot", otHeader(1) + otNode(3.5f, 0)});
  // Only occupied leaves, as binary records.
  files.push_back({"occupied.bt", btHeader(9) + btRecord(kBtOccupied, kBtOccupied)});
  for (const auto& [name, bytes] : files) {
    const std::string path = dir.path(name);
    writeBytes(path, bytes);
    EXPECT_TRUE(failsWith(loadMap(path), StatusCode::kFailedPrecondition, path, "empty map")) << name;
  }
  // Control: one free leaf among the occupied ones is a (tiny) map.
  const std::string path = dir.path("one_free.bt");
  writeBytes(path, btHeader(9) + btRecord(kBtFree, kBtOccupied));
  EXPECT_TRUE(loadMap(path).ok());
}

// ---------------------------------------------------------------------------------------------
// 4. Atomic writes

TEST(MapIoAtomicWrite, FailingWriterLeavesTheTargetUntouched) {
  ScratchDir dir;
  const std::string target = dir.path("map.bt");
  writeBytes(target, "previous content\n");
  const std::string big(1 << 20, 'z');  // enough that a partial write would reach the disk

  Status s = writeFileAtomically(target, [&](std::ostream& os) {
    os << big;
    return false;
  });
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(target), std::string::npos) << s.message();
  EXPECT_EQ(readBytes(target), "previous content\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});

  s = writeFileAtomically(target, [&](std::ostream& os) -> bool {
    os << big;
    throw std::runtime_error("writer exploded");
  });
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find(target), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("writer exploded"), std::string::npos) << s.message();
  EXPECT_EQ(readBytes(target), "previous content\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});

  // A stream that went bad counts as a failure even if the writer says true.
  s = writeFileAtomically(target, [&](std::ostream& os) {
    os << "half";
    os.setstate(std::ios::badbit);
    return true;
  });
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(readBytes(target), "previous content\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});

  // A non-standard exception is contained as well.
  s = writeFileAtomically(target, [&](std::ostream&) -> bool { throw 42; });
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(readBytes(target), "previous content\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});

  // Without a previous file, nothing is created.
  const std::string fresh = dir.path("fresh.ot");
  s = writeFileAtomically(fresh, [&](std::ostream&) { return false; });
  ASSERT_FALSE(s.ok());
  EXPECT_FALSE(fs::exists(fresh));
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});

  // And a successful write replaces the content in one step.
  s = writeFileAtomically(target, [&](std::ostream& os) { return bool(os << "new content\n"); });
  ASSERT_TRUE(s.ok()) << s.toString();
  EXPECT_EQ(readBytes(target), "new content\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});
}

TEST(MapIoAtomicWrite, BadDestinations) {
  ScratchDir dir;
  // Into a directory that does not exist: a clear error, and the directory is not created.
  const std::string missing = dir.path("nope/sub/map.bt");
  bool called = false;
  Status s = writeFileAtomically(missing, [&](std::ostream&) { called = true; return true; });
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find(missing), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("does not exist"), std::string::npos) << s.message();
  EXPECT_FALSE(called);
  EXPECT_FALSE(fs::exists(dir.path("nope")));
  s = writeOctomap(*fixture().map, missing);
  ASSERT_FALSE(s.ok());
  EXPECT_FALSE(fs::exists(dir.path("nope")));
  // The parent is a file, not a directory.
  writeBytes(dir.path("plain"), "x");
  s = writeOctomap(*fixture().map, dir.path("plain/map.bt"));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(readBytes(dir.path("plain")), "x");
  // The target is a directory.
  fs::create_directory(dir.path("taken.bt"));
  s = writeOctomap(*fixture().map, dir.path("taken.bt"));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(fs::is_directory(dir.path("taken.bt")));
  EXPECT_TRUE(fs::is_empty(dir.path("taken.bt")));
  // Unsupported extensions, and .yaml (an octree is not a survey network).
  for (const char* name : {"map.pcd", "map", "map.yaml", "map.yml"}) {
    const std::string p = dir.path(name);
    s = writeOctomap(*fixture().map, p);
    ASSERT_FALSE(s.ok()) << name;
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << name;
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
    EXPECT_FALSE(fs::exists(p)) << name;
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"plain", "taken.bt"}));
}

TEST(MapIoAtomicWrite, RelativePathInTheCurrentDirectory) {
  ScratchDir dir;
  const fs::path cwd = fs::current_path();
  fs::current_path(dir.dir());
  const Status s = writeOctomap(*fixture().map, "here.bt");
  const bool loaded = loadMap("here.bt").ok();
  fs::current_path(cwd);
  ASSERT_TRUE(s.ok()) << s.toString();
  EXPECT_TRUE(loaded);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"here.bt"});
}

TEST(MapIoAtomicWrite, OverwritesAnExistingMap) {
  ScratchDir dir;
  const std::string path = dir.path("map.ot");
  writeBytes(path, "garbage that is not a map");
  ASSERT_TRUE(writeOctomap(*fixture().map, path).ok());
  EXPECT_EQ(readBytes(path), fixture().ot);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.ot"});
}

TEST(MapIoAtomicWrite, SymlinksAreFollowedAndKept) {
  ScratchDir dir;
  fs::create_directory(dir.path("real"));
  writeBytes(dir.path("real/map.bt"), "old");
  fs::create_symlink("real/map.bt", dir.path("link.bt"));  // relative to the link's directory
  fs::create_symlink(dir.path("link.bt"), dir.path("chain.bt"));  // a chain, absolute
  ASSERT_TRUE(writeOctomap(*fixture().map, dir.path("chain.bt")).ok());
  EXPECT_TRUE(fs::is_symlink(dir.path("chain.bt")));
  EXPECT_TRUE(fs::is_symlink(dir.path("link.bt")));
  EXPECT_EQ(readBytes(dir.path("real/map.bt")), fixture().bt);
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"chain.bt", "link.bt", "real"}));
  EXPECT_EQ(fs::directory_iterator(dir.path("real"))->path().filename(), "map.bt");  // no temp file left

  // A dangling link creates its target and stays a link.
  fs::create_symlink("real/new.bt", dir.path("dangling.bt"));
  ASSERT_TRUE(writeFileAtomically(dir.path("dangling.bt"), [](std::ostream& os) { return bool(os << "x"); }).ok());
  EXPECT_TRUE(fs::is_symlink(dir.path("dangling.bt")));
  EXPECT_EQ(readBytes(dir.path("real/new.bt")), "x");

  // A loop is refused with a message, and nothing is created.
  fs::create_symlink("loop_b", dir.path("loop_a"));
  fs::create_symlink("loop_a", dir.path("loop_b"));
  const Status s = writeFileAtomically(dir.path("loop_a"), [](std::ostream& os) { return bool(os << "x"); });
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("symbolic links"), std::string::npos) << s.message();
  EXPECT_TRUE(fs::is_symlink(dir.path("loop_a")));
}

TEST(MapIoAtomicWrite, ReplacedFileKeepsItsPermissions) {
  ScratchDir dir;
  const std::string path = dir.path("map.bt");
  writeBytes(path, "old");
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  ASSERT_TRUE(writeOctomap(*fixture().map, path).ok());
  EXPECT_EQ(fs::status(path).permissions(), fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
}

TEST(MapIoAtomicWrite, CharacterDeviceIsWrittenThroughNotReplaced) {
  // /dev/null itself, as a user would give it: needs no privilege, so it always runs.
  EXPECT_TRUE(writeFileAtomically("/dev/null", [](std::ostream& os) { return bool(os << "x"); }).ok());
  EXPECT_EQ(fs::status("/dev/null").type(), fs::file_type::character);
  // A copy of /dev/null (major 1, minor 3) in a scratch directory, where a temp file and a rename
  // would be visible; creating device nodes needs root (CAP_MKNOD), which the quick start has.
  ScratchDir dir;
  const std::string path = dir.path("null.bt");
  if (::mknod(path.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
    ASSERT_TRUE(writeOctomap(*fixture().map, path).ok());
    EXPECT_EQ(fs::status(path).type(), fs::file_type::character);
    EXPECT_EQ(dir.entries(), std::vector<std::string>{"null.bt"});
  }
}

TEST(MapIoAtomicWrite, FifoIsWrittenThroughToItsReader) {
  ScratchDir dir;
  const std::string path = dir.path("pipe.bt");
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0) << std::strerror(errno);
  std::future<std::string> received = std::async(std::launch::async, [&] { return readBytes(path); });
  ASSERT_TRUE(writeOctomap(*fixture().map, path).ok());
  ASSERT_EQ(received.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_EQ(received.get(), fixture().bt);
  EXPECT_EQ(fs::status(path).type(), fs::file_type::fifo);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"pipe.bt"});
}

// A child process writes slowly; a signal in the middle kills it and leaves no temporary file,
// and the previous content of the target untouched.
void expectSignalLeavesNoTempFile(int sig) {
  ScratchDir dir;
  const std::string target = dir.path("map.bt");
  writeBytes(target, "previous content\n");
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const Status s = writeFileAtomically(target, [](std::ostream& os) {
      os << std::string(1 << 16, 'x');
      os.flush();  // the temporary file now exists and holds data
      for (int i = 0; i < 600; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return true;
    });
    ::_exit(s.ok() ? 0 : 3);
  }
  // Wait until the temporary file has data, then interrupt.
  bool started = false;
  for (int i = 0; i < 3000 && !started; ++i) {
    for (const auto& e : fs::directory_iterator(dir.dir()))
      if (e.path().filename() != "map.bt" && fs::file_size(e.path()) > 0) started = true;
    if (!started) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(started);
  ASSERT_EQ(::kill(pid, sig), 0);
  int wstatus = 0;
  ASSERT_EQ(::waitpid(pid, &wstatus, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(wstatus)) << "child exited normally with " << WEXITSTATUS(wstatus);
  EXPECT_EQ(WTERMSIG(wstatus), sig);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"map.bt"});
  EXPECT_EQ(readBytes(target), "previous content\n");
}

TEST(MapIoAtomicWrite, InterruptLeavesNoTempFile) { expectSignalLeavesNoTempFile(SIGINT); }
TEST(MapIoAtomicWrite, TerminateLeavesNoTempFile) { expectSignalLeavesNoTempFile(SIGTERM); }

TEST(MapIoAtomicWrite, PreviousSignalHandlersAreRestored) {
  struct sigaction before {};
  ASSERT_EQ(::sigaction(SIGINT, nullptr, &before), 0);
  ScratchDir dir;
  ASSERT_TRUE(writeFileAtomically(dir.path("a"), [](std::ostream& os) { return bool(os << "x"); }).ok());
  struct sigaction after {};
  ASSERT_EQ(::sigaction(SIGINT, nullptr, &after), 0);
  EXPECT_EQ(after.sa_handler, before.sa_handler);
}

// ---------------------------------------------------------------------------------------------
// 5. Survey files through loadMap

// The issue's example with the roadways shortened from 300 m to 30 m so that every cut that
// parses can be voxelized quickly.
const std::string kSurvey = test::shortIssueSurveyExample();

std::string replaceOnce(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return at == std::string::npos ? s : s.replace(at, from.size(), to);
}

TEST(MapIoSurvey, YamlGoesThroughTheVoxelizer) {
  ScratchDir dir;
  StatusOr<SurveyNetwork> net = parseSurvey(kSurvey, "x.yaml");
  ASSERT_TRUE(net.ok()) << net.status().toString();
  StatusOr<OccupancyMap> direct = voxelize(*net);
  ASSERT_TRUE(direct.ok()) << direct.status().toString();
  for (const char* name : {"district.yaml", "district.YML"}) {
    const std::string path = dir.path(name);
    writeBytes(path, kSurvey);
    int progress_calls = 0;
    LoadOptions o;
    o.progress = [&](const char*, double f) {
      ++progress_calls;
      EXPECT_TRUE(f >= 0.0 && f <= 1.0) << f;
    };
    StatusOr<OccupancyMap> m = loadMap(path, o);
    ASSERT_TRUE(m.ok()) << m.status().toString();
    EXPECT_GT(progress_calls, 0);
    expectSameMap(*direct, *m, 3);
    EXPECT_TRUE(m->isFree({15.0, 0.0, 1.5 + 1.5}));
  }
}

TEST(MapIoSurvey, TruncatedYamlParsesOrFailsNamingTheFile) {
  ScratchDir dir;
  const std::string path = dir.path("cut.yaml");
  const std::string text = kSurvey;
  int parsed = 0, refused = 0;
  const auto t0 = Clock::now();
  for (std::size_t cut = 0; cut <= text.size(); ++cut) {
    writeBytes(path, text.substr(0, cut));
    StatusOr<OccupancyMap> m = loadMap(path);
    if (m.ok()) {
      ++parsed;
      EXPECT_GT(m->stats().free_voxels, 0u);
    } else {
      ++refused;
      EXPECT_EQ(m.status().message().rfind(path, 0), 0u) << "cut " << cut << ": " << m.status().message();
      EXPECT_NE(m.status().code(), StatusCode::kInternal) << m.status().message();
    }
  }
  std::printf("[          ] %zu cuts: %d parsed, %d refused (%.2f s)\n", text.size() + 1, parsed, refused,
              secondsSince(t0));
  EXPECT_GE(parsed, 1);  // at least the whole file
  EXPECT_GT(refused, int(text.size()) / 2);
}

TEST(MapIoSurvey, MalformedYamlThroughLoadMap) {
  ScratchDir dir;
  const std::string path = dir.path("bad.yaml");
  struct Case {
    const char* what;
    std::string yaml;
    StatusCode code;
  };
  const std::vector<Case> cases = {
      {"empty", "", StatusCode::kInvalidArgument},
      {"binary junk", std::string("\0\x01\x02\xff\xfe", 5), StatusCode::kInvalidArgument},
      {"an OctoMap with a .yaml name", fixture().bt, StatusCode::kInvalidArgument},
      {"unclosed flow", replaceOnce(kSurvey, "[S1, S2]", "[S1, S2"), StatusCode::kInvalidArgument},
      {"tab indentation", replaceOnce(kSurvey, "  S1:", "\tS1:"), StatusCode::kInvalidArgument},
      {"deep nesting", std::string(5000, '[') + std::string(5000, ']'), StatusCode::kInvalidArgument},
      {"very deep nesting", std::string(100000, '{') + std::string(100000, '}'), StatusCode::kInvalidArgument},
  };
  for (const Case& c : cases) {
    writeBytes(path, c.yaml);
    StatusOr<OccupancyMap> m = loadMap(path);
    ASSERT_FALSE(m.ok()) << c.what;
    EXPECT_EQ(m.status().code(), c.code) << c.what << ": " << m.status().message();
    EXPECT_EQ(m.status().message().rfind(path, 0), 0u) << c.what << ": " << m.status().message();
  }
}

TEST(MapIoSurvey, HugeNetworksAreRefusedBeforeAllocating) {
  ScratchDir dir;
  const std::string path = dir.path("huge.yaml");
  struct Case {
    const char* what;
    std::string yaml;
    const char* expect;
  };
  const std::string km3 = replaceOnce(replaceOnce(kSurvey, "S2: [30, 0, 3]", "S2: [1500, 0, 3]"), "S1: [0, 0, 0]",
                                      "S1: [-1500, 0, 0]");
  const std::vector<Case> cases = {
      {"a section 10 km wide", replaceOnce(kSurvey, "width: 4.5", "width: 10000"), "voxels"},
      {"a section 20 km wide", replaceOnce(kSurvey, "width: 4.5", "width: 20000"), "16-bit keys"},
      {"1 mm voxels over 3 km", replaceOnce(km3, "resolution: 0.2", "resolution: 0.001"), "16-bit keys"},
      // Fits the key range but needs about 6e8 voxels: over voxelize's default limit.
      {"5 cm voxels over 3 km", replaceOnce(km3, "resolution: 0.2", "resolution: 0.05"), "coarser resolution"},
      // Over the survey validator's absolute limit (3e9 voxels).
      {"2 cm voxels, 60 m section, 1.2 km",
       replaceOnce(replaceOnce(replaceOnce(replaceOnce(kSurvey, "resolution: 0.2", "resolution: 0.02"),
                                           "S2: [30, 0, 3]", "S2: [600, 0, 3]"),
                               "S1: [0, 0, 0]", "S1: [-600, 0, 0]"),
                   "width: 5.0, wall_height: 3.0", "width: 60.0, wall_height: 30.0"),
       "coarser resolution"},
  };
  for (const Case& c : cases) {
    writeBytes(path, c.yaml);
    const auto t0 = Clock::now();
    StatusOr<OccupancyMap> m = loadMap(path);
    const double seconds = secondsSince(t0);
    ASSERT_FALSE(m.ok()) << c.what;
    EXPECT_EQ(m.status().code(), StatusCode::kOutOfRange) << c.what << ": " << m.status().message();
    EXPECT_EQ(m.status().message().rfind(path, 0), 0u) << c.what << ": " << m.status().message();
    EXPECT_NE(m.status().message().find(c.expect), std::string::npos) << c.what << ": " << m.status().message();
    EXPECT_LT(seconds, 5.0 * kSlowdown) << c.what;  // a hang guard (refusal is milliseconds), not a speed test
  }
}

// ---------------------------------------------------------------------------------------------
// 6. The real Freiburg building map (registered only when the shared data exists; CMake defines
// ADIT_HAVE_SHARED_DATA then).

#ifdef ADIT_HAVE_SHARED_DATA
const std::string kFreiburg = std::string(ADIT_SHARED_DATA_DIR) + "/octomap_samples/geb079.bt";

TEST(MapIoFreiburg, Geb079LoadsWithPlausibleContent) {
  const auto t0 = Clock::now();
  StatusOr<OccupancyMap> m = loadMap(kFreiburg);
  ASSERT_TRUE(m.ok()) << m.status().toString();
  const MapStats& s = m->stats();
  std::printf("[          ] geb079.bt: res %.3f m, %llu nodes, %llu free / %llu occupied voxels, bounds [%.2f %.2f %.2f]"
              " .. [%.2f %.2f %.2f], %.2f s\n",
              s.resolution_m, (unsigned long long)s.octree_nodes, (unsigned long long)s.free_voxels,
              (unsigned long long)s.occupied_voxels, s.bounds.min.x(), s.bounds.min.y(), s.bounds.min.z(),
              s.bounds.max.x(), s.bounds.max.y(), s.bounds.max.z(), secondsSince(t0));
  // Facts from ../shared/data/octomap_samples/SOURCES.md (checked with liboctomap's readBinary).
  EXPECT_NEAR(s.resolution_m, 0.08, 1e-12);
  EXPECT_EQ(s.octree_nodes, 532566u);
  std::uint64_t free_leaves = 0, occupied_leaves = 0;
  m->forEachLeaf([&](const Vec3&, double, VoxelState st) {
    (st == VoxelState::kFree ? free_leaves : occupied_leaves) += 1;
  });
  EXPECT_EQ(free_leaves, 284415u);
  EXPECT_EQ(occupied_leaves, 143729u);
  EXPECT_GT(s.free_voxels, free_leaves);  // pruned free leaves count several voxels
  EXPECT_NEAR(s.bounds.min.x(), -8.00, 0.1);
  EXPECT_NEAR(s.bounds.max.x(), 30.96, 0.1);
  EXPECT_NEAR(s.bounds.min.y(), -7.52, 0.1);
  EXPECT_NEAR(s.bounds.max.y(), 7.44, 0.1);
  EXPECT_NEAR(s.bounds.min.z(), -0.32, 0.1);
  EXPECT_NEAR(s.bounds.max.z(), 2.80, 0.1);
}

TEST(MapIoFreiburg, Geb079RoundTripsAndRefusesCuts) {
  StatusOr<OccupancyMap> m = loadMap(kFreiburg);
  ASSERT_TRUE(m.ok()) << m.status().toString();
  ScratchDir dir;
  std::uint64_t seed = 79;
  for (const FormatCase& f : kFormats) {
    const std::string path = dir.path(std::string("geb079") + f.ext);
    ASSERT_TRUE(writeOctomap(*m, path).ok());
    StatusOr<OccupancyMap> back = loadMap(path);
    ASSERT_TRUE(back.ok()) << back.status().toString();
    expectSameMap(*m, *back, seed++);
  }
  // Our .bt output is byte-identical to the original's data section.
  const std::string original = readBytes(kFreiburg), ours = readBytes(dir.path("geb079.bt"));
  EXPECT_EQ(original.substr(dataOffset(original)), ours.substr(dataOffset(ours)));
  const std::size_t data = dataOffset(original);
  for (std::size_t cut = data; cut < original.size(); cut += (original.size() - data) / 23)
    EXPECT_TRUE(failsWith(parseOctomap(original.substr(0, cut), "geb079.bt"), StatusCode::kDataLoss, "geb079.bt"))
        << cut;
}
#endif  // ADIT_HAVE_SHARED_DATA

}  // namespace
}  // namespace adit::map
