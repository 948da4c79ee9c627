// SPDX-License-Identifier: BSD-3-Clause
// The map cache: a world read back from it is the world a fresh build gives (every voxel's
// state, distance, gradient and nearest rock voxel; every octree leaf), and a cache file that is
// corrupt, truncated, of another version, of another map or of another policy is refused and
// rebuilt, never trusted. A map in a folder that cannot be written is cached in the user's
// folder instead. Oracle: World::load with the cache off.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <linux/fs.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <fstream>
#include <map>
#include <tuple>

#include <octomap/OcTree.h>

#include "adit/map/content_hash.hpp"
#include "adit/map/file_io.hpp"
#include "adit/map/map_cache.hpp"
#include "adit/map/world.hpp"
#include "support/survey_example.hpp"

namespace adit::map {
namespace {

namespace fs = std::filesystem;

class MapCache : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::TempDir() + "adit_map_cache_" + std::to_string(::getpid()) + "_" +
           testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(dir_);
    fs::create_directories(dir_ + "/maps");
    map_ = dir_ + "/maps/mine.yaml";
    ASSERT_TRUE(writeFileAtomically(map_, [](std::ostream& o) { return bool(o << test::shortIssueSurveyExample()); }).ok());
    options_.cache.enabled = true;
    options_.cache.user_dir = dir_ + "/user-cache";
  }
  void TearDown() override {
    setImmutable(dir_ + "/maps", false);
    fs::permissions(dir_ + "/maps", fs::perms::owner_all, fs::perm_options::add);
    fs::remove_all(dir_);
  }
  // chattr +i: the one way to make a folder unwritable for root, who ignores permission bits.
  static bool setImmutable(const std::string& path, bool on) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY);
    if (fd < 0) return false;
    int flags = 0;
    bool ok = ::ioctl(fd, FS_IOC_GETFLAGS, &flags) == 0;
    flags = on ? (flags | FS_IMMUTABLE_FL) : (flags & ~FS_IMMUTABLE_FL);
    ok = ok && ::ioctl(fd, FS_IOC_SETFLAGS, &flags) == 0;
    ::close(fd);
    return ok;
  }
  std::string beside() const { return mapCachePaths(map_, UnknownPolicy::kRock, options_.cache).beside; }
  StatusOr<World> load() const { return World::load(map_, options_); }

  std::string dir_, map_;
  WorldOptions options_;
};

// Every voxel centre of the bounds grown by two voxels: state, and the field's every answer.
void expectSameWorld(const World& a, const World& b) {
  ASSERT_EQ(a.map().resolution(), b.map().resolution());
  const MapStats& sa = a.map().stats();
  const MapStats& sb = b.map().stats();
  EXPECT_EQ(sa.free_voxels, sb.free_voxels);
  EXPECT_EQ(sa.occupied_voxels, sb.occupied_voxels);
  EXPECT_EQ(sa.unknown_voxels, sb.unknown_voxels);
  EXPECT_EQ(sa.octree_nodes, sb.octree_nodes);
  EXPECT_EQ(sa.bounds.min, sb.bounds.min);
  EXPECT_EQ(sa.bounds.max, sb.bounds.max);
  EXPECT_EQ(a.field().stats().blocks, b.field().stats().blocks);
  EXPECT_EQ(a.field().stats().free_voxels, b.field().stats().free_voxels);
  EXPECT_EQ(a.field().stats().max_distance_m, b.field().stats().max_distance_m);
  const double res = a.map().resolution();
  const Vec3 lo = sa.bounds.min - Vec3::Constant(2 * res), hi = sa.bounds.max + Vec3::Constant(2 * res);
  std::size_t voxels = 0, free = 0;
  for (double z = lo.z() + 0.5 * res; z < hi.z(); z += res)
    for (double y = lo.y() + 0.5 * res; y < hi.y(); y += res)
      for (double x = lo.x() + 0.5 * res; x < hi.x(); x += res) {
        const Vec3 p(x, y, z);
        ++voxels;
        ASSERT_EQ(a.map().state(p), b.map().state(p)) << p.transpose();
        ASSERT_EQ(a.field().isFree(p), b.field().isFree(p)) << p.transpose();
        free += a.field().isFree(p);
        const DistanceSample da = a.field().query(p), db = b.field().query(p);
        ASSERT_EQ(da.distance, db.distance) << p.transpose();
        ASSERT_EQ(da.gradient, db.gradient) << p.transpose();
        ASSERT_EQ(da.nearest, db.nearest) << p.transpose();
        ASSERT_EQ(a.field().nearestRockVoxel(p), b.field().nearestRockVoxel(p)) << p.transpose();
      }
  EXPECT_GT(free, 1000u) << "the map should have roadway in it (" << voxels << " voxels visited)";
  // The octree, leaf by leaf.
  std::map<std::tuple<double, double, double, double>, VoxelState> la, lb;
  a.map().forEachLeaf([&](const Vec3& c, double s, VoxelState v) { la[{c.x(), c.y(), c.z(), s}] = v; });
  b.map().forEachLeaf([&](const Vec3& c, double s, VoxelState v) { lb[{c.x(), c.y(), c.z(), s}] = v; });
  EXPECT_EQ(la, lb);
}

World freshWorld(const std::string& path) {
  StatusOr<World> w = World::load(path);
  EXPECT_TRUE(w.ok()) << w.status().message();
  return std::move(w).value();
}

TEST_F(MapCache, ACachedLoadIsTheWorldAFreshBuildGives) {
  StatusOr<World> first = load();
  ASSERT_TRUE(first.ok()) << first.status().message();
  EXPECT_TRUE(first->cacheReport().used.empty());
  EXPECT_EQ(first->cacheReport().written, beside());
  ASSERT_TRUE(fs::exists(beside()));
  StatusOr<World> cached = load();
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  EXPECT_EQ(cached->cacheReport().used, beside());
  EXPECT_TRUE(cached->cacheReport().refused.empty());
  EXPECT_TRUE(cached->cacheReport().written.empty());
  ASSERT_NE(cached->survey(), nullptr);  // parsed again from the survey file
  EXPECT_EQ(cached->survey()->roadways.size(), 2u);
  expectSameWorld(freshWorld(map_), *cached);
}

TEST_F(MapCache, ACachedWorldChangesLikeAFreshOne) {
  // The navigator writes into its belief: the octree read from the cache must take writes and
  // the field update as a built one does.
  ASSERT_TRUE(load().ok());
  StatusOr<World> cached = load();
  ASSERT_TRUE(cached.ok());
  ASSERT_FALSE(cached->cacheReport().used.empty());
  World fresh = freshWorld(map_);
  const std::vector<Vec3> rubble = {{10.1, 0.1, 1.1}, {10.3, 0.1, 1.1}, {10.1, 0.3, 1.3}};
  for (World* w : {&fresh, &*cached}) {
    MapChange change;
    ASSERT_TRUE(w->map().setVoxels(rubble, VoxelState::kOccupied, &change).ok());
    ASSERT_EQ(change.to_occupied, 3u);
    ASSERT_TRUE(w->field().update(w->map(), change.box).ok());
  }
  expectSameWorld(fresh, *cached);
}

TEST_F(MapCache, ACopyOfACachedWorldSharesNothingAChangeReaches) {
  ASSERT_TRUE(load().ok());
  StatusOr<World> cached = load();
  ASSERT_TRUE(cached.ok());
  World belief = cached->copy();
  const Vec3 p(10.1, 0.1, 1.1);
  ASSERT_EQ(cached->map().state(p), VoxelState::kFree);
  ASSERT_TRUE(belief.map().setVoxel(p, VoxelState::kOccupied).ok());
  EXPECT_EQ(belief.map().state(p), VoxelState::kOccupied);
  EXPECT_EQ(cached->map().state(p), VoxelState::kFree);
}

// An octree with leaves of every size a cached map's voxel states file differently: a free cube
// of 64^3 voxels and more (whole superblocks), free and occupied cubes of 8-32 (whole bricks),
// single voxels of both states and unknown holes (split bricks), written as .ot (log-odds kept).
std::string writeOctree(const std::string& path, const std::function<void(octomap::OcTree&)>& more = {}) {
  octomap::OcTree t(0.2);
  const float occupied = t.getClampingThresMaxLog(), free = t.getClampingThresMinLog();
  constexpr unsigned kC = 32768;  // the key of coordinate 0
  for (unsigned z = kC - 8; z < kC + 72; ++z)
    for (unsigned y = kC - 8; y < kC + 72; ++y)
      for (unsigned x = kC - 8; x < kC + 140; ++x) {
        const bool shell = x == kC - 8 || x == kC + 139 || y == kC - 8 || y == kC + 71 || z == kC - 8 || z == kC + 71;
        const bool rubble = x >= kC + 96 && x < kC + 112 && y >= kC + 16 && y < kC + 32 && z < kC + 8;
        t.setNodeValue(octomap::OcTreeKey(std::uint16_t(x), std::uint16_t(y), std::uint16_t(z)), shell || rubble ? occupied : free,
                       /*lazy_eval=*/true);
      }
  std::uint64_t s = 12345;  // single voxels: rock specks and unknown holes, away from the 64^3 cube
  for (int i = 0; i < 400; ++i) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    const octomap::OcTreeKey k(std::uint16_t(kC + 70 + (s >> 33) % 60), std::uint16_t(kC + (s >> 43) % 60),
                               std::uint16_t(kC + (s >> 53) % 60));
    if (i % 3 == 0) t.deleteNode(k);
    else t.setNodeValue(k, i % 3 == 1 ? occupied : free, true);
  }
  if (more) more(t);
  t.updateInnerOccupancy();
  t.prune();
  EXPECT_TRUE(t.write(path));
  return path;
}

// Every voxel of `box` (grown by two voxels) has the state a fresh load gives, in the map and in
// a copy after the same scan (what a campaign's believed map is).
void expectSameStates(const World& fresh, const World& cached, const Aabb& box) {
  const double res = fresh.map().resolution();
  std::size_t known = 0;
  for (double z = box.min.z() - 1.5 * res; z < box.max.z() + 2 * res; z += res)
    for (double y = box.min.y() - 1.5 * res; y < box.max.y() + 2 * res; y += res)
      for (double x = box.min.x() - 1.5 * res; x < box.max.x() + 2 * res; x += res) {
        const Vec3 p(x, y, z);
        ASSERT_EQ(fresh.map().state(p), cached.map().state(p)) << p.transpose();
        ASSERT_EQ(fresh.map().isFree(p), cached.map().isFree(p)) << p.transpose();
        known += fresh.map().state(p) != VoxelState::kUnknown;
      }
  EXPECT_GT(known, 100000u);
  World a = fresh.copy(), b = cached.copy();
  std::vector<Vec3> returns;
  for (int i = 0; i < 200; ++i)
    returns.push_back(Vec3(1.0, 1.0, 1.0) + 30.0 * Vec3(std::cos(0.1 * i), std::sin(0.1 * i), 0.02 * (i % 10) - 0.1));
  const StatusOr<MapChange> ca = a.map().insertRays({1.0, 1.0, 1.0}, returns, 20.0);
  const StatusOr<MapChange> cb = b.map().insertRays({1.0, 1.0, 1.0}, returns, 20.0);
  ASSERT_TRUE(ca.ok() && cb.ok());
  EXPECT_GT(ca->changed(), 0u);
  EXPECT_EQ(ca->to_free, cb->to_free);
  EXPECT_EQ(ca->to_occupied, cb->to_occupied);
  EXPECT_EQ(ca->box.min, cb->box.min);
  EXPECT_EQ(ca->box.max, cb->box.max);
  std::vector<char> va, vb;
  a.map().lineOfSight({1.0, 1.0, 1.0}, returns, va);
  b.map().lineOfSight({1.0, 1.0, 1.0}, returns, vb);
  EXPECT_EQ(va, vb);
  EXPECT_EQ(a.map().stats().octree_nodes, b.map().stats().octree_nodes);
}

TEST_F(MapCache, ACachedMapsVoxelStatesAreTheOctreesAtEveryVoxel) {
  // Oracle: OcTree::search() on the fresh load's octree, voxel by voxel.
  const std::string ot = writeOctree(dir_ + "/maps/cubes.ot");
  ASSERT_TRUE(World::load(ot, options_).ok());
  StatusOr<World> cached = World::load(ot, options_);
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  ASSERT_FALSE(cached->cacheReport().used.empty());
  const World fresh = freshWorld(ot);
  expectSameStates(fresh, *cached, fresh.map().bounds());
  // The leaves read from the bytes come in the tree iterator's order, with its centres and sizes.
  std::vector<std::tuple<double, double, double, double, VoxelState>> la, lb;
  fresh.map().forEachLeaf([&](const Vec3& c, double e, VoxelState v) { la.emplace_back(c.x(), c.y(), c.z(), e, v); });
  cached->map().forEachLeaf([&](const Vec3& c, double e, VoxelState v) { lb.emplace_back(c.x(), c.y(), c.z(), e, v); });
  EXPECT_EQ(la, lb);
  EXPECT_GT(std::count_if(la.begin(), la.end(), [](const auto& l) { return std::get<3>(l) > 12.0; }), 0)
      << "a leaf of 64^3 voxels or more";
  expectSameWorld(fresh, *cached);
}

TEST_F(MapCache, AMapWhoseLeavesSpanTheKeyRangeAnswersFromItsOctree) {
  // A rock leaf of 16384^3 voxels (keys 0-16383) away from the roadway: the states would need
  // more superblocks than they allow, so the cached map's octree answers, as it must, the same.
  const std::string ot = writeOctree(dir_ + "/maps/half.ot", [](octomap::OcTree& t) {
    ASSERT_TRUE(t.nodeChildExists(t.getRoot(), 0));  // the roadway's corner, in its child 7
    octomap::OcTreeNode* lower = t.getNodeChild(t.getRoot(), 0);
    ASSERT_FALSE(t.nodeChildExists(lower, 0));
    octomap::OcTreeNode* rock = t.createNodeChild(lower, 0);
    rock->setLogOdds(t.getClampingThresMaxLog());
  });
  const StatusOr<World> first = World::load(ot, options_);
  ASSERT_TRUE(first.ok()) << first.status().message();
  StatusOr<World> cached = World::load(ot, options_);
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  ASSERT_FALSE(cached->cacheReport().used.empty());
  const World fresh = freshWorld(ot);
  const Vec3 far(-5000.0, -4000.0, -4000.0);  // key 7768, 12768, 12768
  ASSERT_EQ(cached->map().state(far), VoxelState::kOccupied);
  Aabb roadway;
  roadway.extend(Vec3(-1.6, -1.6, -1.6));
  roadway.extend(Vec3(28.0, 14.4, 14.4));
  expectSameStates(fresh, *cached, roadway);
}

// Flips one byte at `offset` from the end (or the start) of the cache file.
void flipByte(const std::string& path, std::int64_t offset) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  const auto size = std::int64_t(fs::file_size(path));
  const std::int64_t at = offset >= 0 ? offset : size + offset;
  f.seekg(at);
  char c = 0;
  f.get(c);
  f.seekp(at);
  f.put(char(c ^ 0x40));
}

TEST_F(MapCache, ACorruptCacheIsRefusedAndRebuilt) {
  ASSERT_TRUE(load().ok());
  const auto size = std::int64_t(fs::file_size(beside()));
  // A byte in the header, in the statistics or the octree after it, in the middle of the tiles
  // and in the last tile: the sections lie back to back, every byte under a checksum.
  for (std::int64_t offset : {std::int64_t(20), std::int64_t(300),
                              size / 2, std::int64_t(-7)}) {
    flipByte(beside(), offset);
    StatusOr<World> w = load();
    ASSERT_TRUE(w.ok()) << w.status().message();
    EXPECT_TRUE(w->cacheReport().used.empty()) << "offset " << offset;
    ASSERT_EQ(w->cacheReport().refused.size(), 1u) << "offset " << offset;
    EXPECT_NE(w->cacheReport().refused[0].find(beside()), std::string::npos) << w->cacheReport().refused[0];
    EXPECT_EQ(w->cacheReport().written, beside());
    // Rebuilt (the same size; the build times it records differ), and the next load reads it.
    EXPECT_EQ(std::int64_t(fs::file_size(beside())), size) << "offset " << offset;
    StatusOr<World> again = load();
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(again->cacheReport().used, beside());
  }
}

TEST_F(MapCache, ATruncatedCacheIsRefusedAndRebuilt) {
  ASSERT_TRUE(load().ok());
  const auto size = fs::file_size(beside());
  for (std::uintmax_t keep : {std::uintmax_t(0), std::uintmax_t(100), std::uintmax_t(5000), size / 2, size - 1}) {
    fs::resize_file(beside(), keep);
    StatusOr<World> w = load();
    ASSERT_TRUE(w.ok()) << w.status().message();
    EXPECT_TRUE(w->cacheReport().used.empty()) << "kept " << keep;
    ASSERT_EQ(w->cacheReport().refused.size(), 1u) << "kept " << keep;
    EXPECT_EQ(fs::file_size(beside()), size);
  }
  // Longer than it says is no better than shorter.
  { std::ofstream(beside(), std::ios::app | std::ios::binary) << "tail"; }
  StatusOr<World> w = load();
  ASSERT_TRUE(w.ok());
  ASSERT_EQ(w->cacheReport().refused.size(), 1u);
  EXPECT_NE(w->cacheReport().refused[0].find("after the last section"), std::string::npos) << w->cacheReport().refused[0];
}

// A hostile cache: the octree's bytes are edited and every checksum made right again, so only the
// check of the stream's shape stands between them and OctoMap's recursive reader. Offsets follow
// map_cache.cpp's header: the octree's section descriptor (offset, size, checksum) at byte 64, the
// header's checksum at byte 208, of the 208 bytes before it.
TEST_F(MapCache, AnOctreeWithRightChecksumsButAWrongShapeIsRefused) {
  ASSERT_TRUE(load().ok());
  std::string pristine;
  {
    std::ifstream in(beside(), std::ios::binary);
    pristine.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto u64 = [](const std::string& b, std::size_t at) {
    std::uint64_t v;
    std::memcpy(&v, b.data() + at, 8);
    return v;
  };
  const std::size_t off = std::size_t(u64(pristine, 64)), size = std::size_t(u64(pristine, 72));
  ASSERT_GT(size, 50u);
  ASSERT_EQ(checksum64(pristine.data() + off, size), u64(pristine, 80)) << "the header layout moved";
  auto install = [&](std::string b) {
    const std::uint64_t section = checksum64(b.data() + off, size);
    std::memcpy(b.data() + 80, &section, 8);
    const std::uint64_t header = checksum64(b.data(), 208);
    std::memcpy(b.data() + 208, &header, 8);
    std::ofstream(beside(), std::ios::binary | std::ios::trunc) << b;
  };
  // Node k's value at off + 5k, its child mask at off + 5k + 4.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::string not_finite = pristine, no_children = pristine, a_child_too_many = pristine;
  std::memcpy(not_finite.data() + off + 5 * 3, &nan, 4);
  no_children[off + 4] = 0;                  // the root ends the tree: the rest is left over
  a_child_too_many[off + size - 1] = 1;      // the last node, a leaf, names a child past the end
  const std::pair<std::string, std::vector<const char*>> cases[] = {
      {not_finite, {"node 4 is cut or not finite"}},
      {no_children, {"bytes after the tree"}},
      {a_child_too_many, {"is cut or not finite", "below depth 16"}}};
  for (const auto& [bytes, whys] : cases) {
    install(bytes);
    StatusOr<World> w = load();
    ASSERT_TRUE(w.ok()) << w.status().message();
    EXPECT_TRUE(w->cacheReport().used.empty()) << whys[0];
    ASSERT_EQ(w->cacheReport().refused.size(), 1u) << whys[0];
    const std::string& why = w->cacheReport().refused[0];
    EXPECT_TRUE(std::any_of(whys.begin(), whys.end(), [&](const char* s) { return why.find(s) != std::string::npos; }))
        << why;
    EXPECT_EQ(w->cacheReport().written, beside());
    expectSameWorld(freshWorld(map_), *w);
  }
}

TEST_F(MapCache, AForeignCacheIsRefusedAndRebuilt) {
  ASSERT_TRUE(load().ok());
  StatusOr<MapCacheKey> key = mapCacheKey(map_, UnknownPolicy::kRock);
  ASSERT_TRUE(key.ok());
  World fresh = freshWorld(map_);
  // Another version, another map (same size, one number changed), another policy.
  MapCacheKey other_version = *key;
  other_version.version = kMapCacheVersion + 1;
  MapCacheKey other_map = *key;
  other_map.map_hash ^= 1;
  MapCacheKey other_policy = *key;
  other_policy.policy = UnknownPolicy::kFree;
  const std::pair<MapCacheKey, const char*> cases[] = {
      {other_version, "version"}, {other_map, "another map"}, {other_policy, "policy"}};
  for (const auto& [foreign, why] : cases) {
    ASSERT_TRUE(writeMapCache(fresh, foreign, beside()).ok());
    StatusOr<World> w = load();
    ASSERT_TRUE(w.ok()) << w.status().message();
    EXPECT_TRUE(w->cacheReport().used.empty()) << why;
    ASSERT_EQ(w->cacheReport().refused.size(), 1u) << why;
    EXPECT_NE(w->cacheReport().refused[0].find(why), std::string::npos) << w->cacheReport().refused[0];
    EXPECT_EQ(w->cacheReport().written, beside());
  }
  // An edited map makes its old cache foreign.
  ASSERT_TRUE(writeFileAtomically(map_, [](std::ostream& o) {
                std::string s = test::shortIssueSurveyExample();
                s.replace(s.find("S3: [30, 8, 4]"), 14, "S3: [30, 9, 4]");
                return bool(o << s);
              }).ok());
  StatusOr<World> edited = load();
  ASSERT_TRUE(edited.ok());
  ASSERT_EQ(edited->cacheReport().refused.size(), 1u);
  EXPECT_NE(edited->cacheReport().refused[0].find("another map"), std::string::npos);
  expectSameWorld(freshWorld(map_), *edited);
}

TEST_F(MapCache, AReadOnlyMapFolderFallsBackToTheUserFolder) {
  fs::permissions(dir_ + "/maps", fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write,
                  fs::perm_options::remove);
  if (::geteuid() == 0) setImmutable(dir_ + "/maps", true);
  const MapCachePaths where = mapCachePaths(map_, UnknownPolicy::kRock, options_.cache);
  // Root on a file system without chattr +i writes into any folder: then the cache file's place
  // beside the map is taken by a non-empty folder, which no one can write a file over, so that the
  // write beside the map fails as it does in a read-only folder.
  const bool blocked = ::access((dir_ + "/maps").c_str(), W_OK) == 0 && std::ofstream(dir_ + "/maps/probe");
  if (blocked) {
    fs::remove(dir_ + "/maps/probe");
    fs::create_directories(where.beside + "/in-the-way");
  }
  ASSERT_EQ(where.user.rfind(options_.cache.user_dir + "/", 0), 0u) << where.user;
  StatusOr<World> first = load();
  ASSERT_TRUE(first.ok()) << first.status().message();
  EXPECT_EQ(first->cacheReport().written, where.user);
  EXPECT_FALSE(fs::is_regular_file(where.beside));
  if (!blocked) {
    EXPECT_FALSE(fs::exists(where.beside));
  }
  StatusOr<World> cached = load();
  ASSERT_TRUE(cached.ok());
  EXPECT_EQ(cached->cacheReport().used, where.user);
  expectSameWorld(freshWorld(map_), *cached);
}

TEST_F(MapCache, OffLoadsNeitherReadNorWrite) {
  options_.cache.enabled = false;
  StatusOr<World> w = load();
  ASSERT_TRUE(w.ok());
  EXPECT_FALSE(fs::exists(beside()));
  EXPECT_TRUE(w->cacheReport().used.empty() && w->cacheReport().written.empty());
}

TEST_F(MapCache, AMissingMapIsTheLoadersErrorNotTheCaches) {
  fs::remove(map_);
  StatusOr<World> w = load();
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.status().message().find("mine.yaml"), std::string::npos) << w.status().message();
}

TEST(MapCacheEnvironment, TheVariableTurnsItOff) {
  const char* was = std::getenv("ADIT_NO_MAP_CACHE");
  const std::string saved = was ? was : "";
  ::setenv("ADIT_NO_MAP_CACHE", "1", 1);
  EXPECT_TRUE(mapCacheDisabledByEnvironment());
  ::setenv("ADIT_NO_MAP_CACHE", "0", 1);
  EXPECT_FALSE(mapCacheDisabledByEnvironment());
  ::unsetenv("ADIT_NO_MAP_CACHE");
  EXPECT_FALSE(mapCacheDisabledByEnvironment());
  if (was) ::setenv("ADIT_NO_MAP_CACHE", saved.c_str(), 1);
}

TEST(Checksum64, SeesEveryByteAndItsPlace) {
  std::string a(1000, 'x');
  const std::uint64_t h = checksum64(a.data(), a.size());
  for (std::size_t i : {std::size_t(0), std::size_t(7), std::size_t(31), std::size_t(500), std::size_t(999)}) {
    std::string b = a;
    b[i] ^= 1;
    EXPECT_NE(checksum64(b.data(), b.size()), h) << i;
  }
  EXPECT_NE(checksum64(a.data(), a.size() - 1), h);
  std::string swapped = a;
  swapped.replace(0, 16, "0123456789abcdef");
  std::string swapped2 = a;
  swapped2.replace(0, 16, "89abcdef01234567");
  EXPECT_NE(checksum64(swapped.data(), swapped.size()), checksum64(swapped2.data(), swapped2.size()));
}

}  // namespace
}  // namespace adit::map
