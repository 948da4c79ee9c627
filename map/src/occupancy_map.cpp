// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/occupancy_map.hpp"

#include <octomap/OcTree.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <mutex>
#include <sstream>
#include <unordered_map>

#include "octree_stream.hpp"
#include "voxel_states.hpp"

namespace adit::map {

const char* voxelStateName(VoxelState s) {
  switch (s) {
    case VoxelState::kFree: return "free";
    case VoxelState::kOccupied: return "occupied";
    case VoxelState::kUnknown: return "unknown";
  }
  return "?";
}

const char* unknownPolicyName(UnknownPolicy p) { return p == UnknownPolicy::kRock ? "rock" : "free"; }

StatusOr<UnknownPolicy> parseUnknownPolicy(const std::string& name) {
  if (name == "rock" || name == "occupied") return UnknownPolicy::kRock;
  if (name == "free") return UnknownPolicy::kFree;
  return invalidArgument("unknown-space policy '" + name + "' is not one of: rock, free");
}

double maxMapExtent(double resolution_m) { return 32768.0 * resolution_m; }

Status checkResolution(double resolution_m) {
  if (!std::isfinite(resolution_m) || resolution_m <= 0.0) {
    std::ostringstream os;
    os << "resolution = " << resolution_m << " must be finite and > 0";
    return invalidArgument(os.str());
  }
  if (resolution_m < 1e-3) {
    std::ostringstream os;
    os << "resolution = " << resolution_m << " m is below the supported minimum of 0.001 m";
    return invalidArgument(os.str());
  }
  // Voxels of more than 100 m describe no roadway, and OctoMap's float coordinates overflow
  // long before keys run out at absurd resolutions.
  if (resolution_m > 100.0) {
    std::ostringstream os;
    os << "resolution = " << resolution_m << " m is above the supported maximum of 100 m";
    return invalidArgument(os.str());
  }
  return {};
}

Status checkExtent(const Aabb& box, double resolution_m) {
  ADIT_RETURN_IF_ERROR(checkResolution(resolution_m));
  if (box.empty()) return {};
  if (!allFinite(box.min) || !allFinite(box.max)) return invalidArgument("map bounds are not finite");
  // Keys are floor(c / res) + 32768 in [0, 65535]; keep one voxel of margin on each side.
  const double lo = -32767.0 * resolution_m, hi = 32766.0 * resolution_m;
  for (int i = 0; i < 3; ++i) {
    if (box.min[i] < lo || box.max[i] > hi) {
      std::ostringstream os;
      os << "map extent [" << box.min.transpose() << "] .. [" << box.max.transpose()
         << "] m does not fit OctoMap's 16-bit keys: at resolution " << resolution_m
         << " m every coordinate must lie within +-" << maxMapExtent(resolution_m)
         << " m of the origin (move the origin or use a coarser resolution)";
      return outOfRange(os.str());
    }
  }
  return {};
}

namespace {
// An OcTree read from OcTree::writeData's bytes as OcTree::readData reads them (the same nodes,
// values, size and flags), but from memory: readData's two std::istream reads a node were a
// third of building the district's 2.6 million nodes, which every campaign worker does once.
class TreeFromBytes : public octomap::OcTree {
 public:
  explicit TreeFromBytes(double resolution_m) : octomap::OcTree(resolution_m) {}
  // False when the bytes end early or are left over (the cache reader checked their shape).
  bool read(const std::string& data) {
    tree_size = 0;
    size_changed = true;
    // A node's parent is the last node read one level up (the stream is depth first).
    octomap::OcTreeNode* last[17];
    const StreamWalk w = walkOctreeStream<false>(data, [&](const StreamNode& n) {
      octomap::OcTreeNode* node = n.depth == 0 ? (root = new octomap::OcTreeNode())
                                               : createNodeChild(last[n.depth - 1], n.child);
      node->setValue(n.log_odds);
      last[n.depth] = node;
      return true;
    });
    tree_size = calcNumNodes();
    return w.end == StreamWalk::kWhole && w.bytes == data.size();
  }
};
}  // namespace

// Built once, by whichever thread asks first; the bytes are checksummed and their shape checked
// by the cache reader, so a failure here is a bug, not bad input. Voxel queries need only the
// states (VoxelStates, from the same bytes, built on the first query) and key arithmetic (an
// empty tree of the same resolution): the nodes are built for whole-tree readers and writers.
struct OccupancyMap::LazyTree {
  LazyTree(std::string d, double r, std::uint64_t n)
      : data(std::make_shared<const std::string>(std::move(d))), nodes(n), keys(r) {}
  // OcTree::writeData's stream (lossless: every node's log-odds), released once the tree is built
  // (under data_mutex: a walk of the leaves holds its own reference).
  std::shared_ptr<const std::string> data;
  std::uint64_t nodes;  // the built tree's size()
  octomap::OcTree keys;  // no nodes: coordToKey, computeRayKeys, keyToCoord, the threshold
  std::once_flag once, states_once;
  std::shared_ptr<octomap::OcTree> tree;
  std::unique_ptr<VoxelStates> states;  // null when the leaves span too much (then the tree answers)
  const std::shared_ptr<octomap::OcTree>& shared() {
    std::call_once(once, [this] {
      // The stream goes below: states not built by now never will be (the tree answers).
      std::call_once(states_once, [] {});
      auto t = std::make_shared<TreeFromBytes>(keys.getResolution());
      ADIT_DEMAND(t->read(*data));  // checked bytes that do not parse: a bug in the cache writer
      tree = std::move(t);
      std::lock_guard<std::mutex> lock(data_mutex);
      data.reset();
    });
    return tree;
  }
  // Every leaf from the bytes, as the tree's leaf iterator gives them (the same order, centres,
  // sizes and states): a map's picture or mesh does not need the nodes. False once the tree is
  // built (the bytes are gone).
  bool forEachLeaf(const std::function<void(const Vec3&, double, VoxelState)>& fn) {
    std::shared_ptr<const std::string> bytes;
    {
      std::lock_guard<std::mutex> lock(data_mutex);
      bytes = data;
    }
    if (!bytes) return false;
    const float occupied = keys.getOccupancyThresLog();
    forEachStreamLeaf(*bytes, [&](const StreamNode& n) {
      const auto depth = unsigned(n.depth);
      fn(Vec3(keys.keyToCoord(octomap::key_type(n.origin[0]), depth), keys.keyToCoord(octomap::key_type(n.origin[1]), depth),
              keys.keyToCoord(octomap::key_type(n.origin[2]), depth)),
         keys.getNodeSize(depth), n.log_odds >= occupied ? VoxelState::kOccupied : VoxelState::kFree);
    });
    return true;
  }
  std::mutex data_mutex;
  const VoxelStates* voxelStates() {
    std::call_once(states_once, [this] { states = VoxelStates::fromStream(*data, keys.getOccupancyThresLog()); });
    return states.get();
  }
};

// A deepCopy()'s changed voxels, each with its state now (kUnknown: deleted); a voxel written
// back to the shared tree's state leaves it. `own`, once made, is the shared tree cloned with
// the changes applied: from then on it is the copy's tree and the changes are not read.
struct OccupancyMap::Overlay {
  std::unordered_map<octomap::OcTreeKey, VoxelState, octomap::OcTreeKey::KeyHash> changes;
  std::atomic<octomap::OcTree*> own{nullptr};
  std::shared_ptr<octomap::OcTree> own_holder;
  std::mutex mutex;  // readers may ask for the whole tree from several threads
};

namespace {
VoxelState nodeState(const octomap::OcTree& tree, const octomap::OcTreeKey& key) {
  const octomap::OcTreeNode* node = tree.search(key);
  if (!node) return VoxelState::kUnknown;
  return tree.isNodeOccupied(node) ? VoxelState::kOccupied : VoxelState::kFree;
}
// The octree's part of a voxel write: what applyKey() and an overlay's clone both do.
void writeNode(octomap::OcTree& tree, const octomap::OcTreeKey& key, VoxelState state) {
  if (state == VoxelState::kUnknown) {
    if (tree.search(key)) tree.deleteNode(key);
    return;
  }
  tree.setNodeValue(key, state == VoxelState::kOccupied ? tree.getClampingThresMaxLog() : tree.getClampingThresMinLog());
}
}  // namespace

OccupancyMap::OccupancyMap(std::shared_ptr<octomap::OcTree> tree, UnknownPolicy policy)
    : tree_(std::move(tree)), policy_(policy) {}

StatusOr<OccupancyMap> OccupancyMap::create(std::shared_ptr<octomap::OcTree> tree, UnknownPolicy policy) {
  if (!tree) return invalidArgument("no octree given");
  ADIT_RETURN_IF_ERROR(checkResolution(tree->getResolution()));
  OccupancyMap map(std::move(tree), policy);
  map.recomputeStats();
  if (map.stats_.free_voxels == 0 && !(policy == UnknownPolicy::kFree && map.stats_.unknown_voxels > 0)) {
    return failedPrecondition("empty map: it has no free voxel (" + std::to_string(map.stats_.occupied_voxels) +
                              " occupied), so there is nowhere to plan");
  }
  return map;
}

StatusOr<OccupancyMap> OccupancyMap::fromVoxels(double resolution_m, const std::vector<Vec3>& free,
                                                const std::vector<Vec3>& occupied, UnknownPolicy policy) {
  ADIT_RETURN_IF_ERROR(checkResolution(resolution_m));
  Aabb box;
  for (const std::vector<Vec3>* list : {&free, &occupied})
    for (std::size_t i = 0; i < list->size(); ++i) {
      const Vec3& p = (*list)[i];
      if (!allFinite(p))
        return invalidArgument(std::string(list == &free ? "free" : "occupied") + " voxel " + std::to_string(i) +
                               " is not finite");
      box.extend(p);
    }
  if (!box.empty()) ADIT_RETURN_IF_ERROR(checkExtent(box, resolution_m));
  auto tree = std::make_shared<octomap::OcTree>(resolution_m);
  const float free_log = tree->getClampingThresMinLog(), occupied_log = tree->getClampingThresMaxLog();
  for (const Vec3& p : free) tree->setNodeValue(p.x(), p.y(), p.z(), free_log);
  for (const Vec3& p : occupied) tree->setNodeValue(p.x(), p.y(), p.z(), occupied_log);
  tree->prune();
  return create(std::move(tree), policy);
}

OccupancyMap OccupancyMap::withUnknownPolicy(UnknownPolicy policy) const {
  OccupancyMap copy = *this;
  copy.policy_ = policy;
  return copy;
}

OccupancyMap OccupancyMap::deepCopy() const {
  // A copy of a copy shares the same original tree: the overlay it starts from is this one's
  // changes (or, once cloned, this one's clone is its original).
  OccupancyMap copy(tree_, policy_);
  copy.lazy_ = lazy_;
  copy.stats_ = stats_;
  copy.overlay_ = std::make_shared<Overlay>();
  if (overlay_) {
    if (overlay_->own.load(std::memory_order_acquire)) {
      copy.tree_ = overlay_->own_holder;
      copy.lazy_.reset();
    } else {
      copy.overlay_->changes = overlay_->changes;
    }
  }
  return copy;
}

// Writes to a map that is no copy go to its (possibly still lazy) tree; a copy's overlay that
// has outgrown its bound becomes the clone.
void OccupancyMap::prepareWrite() {
  if (!overlay_) {
    if (!tree_) {
      tree_ = lazy_->shared();
      lazy_.reset();
    }
    return;
  }
  if (!overlay_->own.load(std::memory_order_acquire) && overlay_->changes.size() >= kMaxOverlayVoxels) (void)tree();
}

double OccupancyMap::resolution() const { return tree_ ? tree_->getResolution() : stats_.resolution_m; }

OccupancyMap OccupancyMap::fromOctreeData(std::string data, UnknownPolicy policy, const MapStats& stats) {
  OccupancyMap map(nullptr, policy);
  map.lazy_ = std::make_shared<LazyTree>(std::move(data), stats.resolution_m, stats.octree_nodes);
  map.stats_ = stats;
  return map;
}

octomap::OcTree& OccupancyMap::lazyTree() const { return *lazy_->shared(); }

const octomap::OcTree& OccupancyMap::keys() const { return tree_ ? *tree_ : lazy_->keys; }

std::uint64_t OccupancyMap::baseNodes() const { return tree_ ? tree_->size() : lazy_->nodes; }

VoxelState OccupancyMap::baseState(const octomap::OcTreeKey& key) const {
  if (!tree_) {
    if (const VoxelStates* states = lazy_->voxelStates()) return states->at(key[0], key[1], key[2]);
  }
  return nodeState(base(), key);
}

void OccupancyMap::prepareVoxelQueries() const {
  if (!tree_ && !lazy_->voxelStates()) (void)lazy_->shared();
}

octomap::OcTree& OccupancyMap::tree() const {
  if (!overlay_) return base();
  Overlay& o = *overlay_;
  if (octomap::OcTree* own = o.own.load(std::memory_order_acquire)) return *own;
  if (o.changes.empty()) return base();  // nothing written yet: the shared tree is this map
  std::lock_guard<std::mutex> lock(o.mutex);
  if (octomap::OcTree* own = o.own.load(std::memory_order_relaxed)) return *own;
  auto clone = std::make_shared<octomap::OcTree>(base());
  for (const auto& [key, state] : o.changes) writeNode(*clone, key, state);
  o.own_holder = clone;
  o.own.store(clone.get(), std::memory_order_release);
  return *clone;
}

std::shared_ptr<const octomap::OcTree> OccupancyMap::sharedOctree() const {
  if (overlay_ && (overlay_->own.load(std::memory_order_acquire) || !overlay_->changes.empty())) {
    (void)tree();
    return overlay_->own_holder;
  }
  return tree_ ? tree_ : lazy_->shared();
}

VoxelState OccupancyMap::keyState(const octomap::OcTreeKey& key) const {
  if (overlay_) {
    if (const octomap::OcTree* own = overlay_->own.load(std::memory_order_acquire)) return nodeState(*own, key);
    if (!overlay_->changes.empty()) {
      auto it = overlay_->changes.find(key);
      if (it != overlay_->changes.end()) return it->second;
    }
  }
  return baseState(key);
}

namespace {
// Unknown = voxels of the bounding box that are neither free nor occupied.
void setUnknownFromBounds(MapStats& s) {
  s.unknown_voxels = 0;
  if (s.bounds.empty()) return;
  const Vec3 n = (s.bounds.size() / s.resolution_m).array().round();
  const double total = n.x() * n.y() * n.z(), known = double(s.free_voxels + s.occupied_voxels);
  s.unknown_voxels = total > known ? std::uint64_t(total - known) : 0;
}
}  // namespace

void OccupancyMap::recomputeStats() {
  MapStats s;
  s.resolution_m = tree().getResolution();
  s.octree_nodes = tree().size();
  forEachLeaf([&](const Vec3& centre, double size, VoxelState state) {
    const auto edge = std::uint64_t(std::llround(size / s.resolution_m));
    (state == VoxelState::kOccupied ? s.occupied_voxels : s.free_voxels) += edge * edge * edge;
    s.bounds.extend(centre - Vec3::Constant(0.5 * size));
    s.bounds.extend(centre + Vec3::Constant(0.5 * size));
  });
  setUnknownFromBounds(s);
  stats_ = s;
}

VoxelState OccupancyMap::state(const Vec3& p) const {
  octomap::OcTreeKey key;
  if (!allFinite(p) || !keys().coordToKeyChecked(p.x(), p.y(), p.z(), key)) return VoxelState::kUnknown;
  return keyState(key);
}

bool OccupancyMap::isFree(const Vec3& p) const {
  // The outermost layer of the key range is rock whatever the tree says, so that every free voxel
  // has representable rock around it (the distance field relies on it).
  octomap::OcTreeKey key;
  if (!allFinite(p) || !keys().coordToKeyChecked(p.x(), p.y(), p.z(), key)) return false;
  for (int a = 0; a < 3; ++a)
    if (key[a] == 0 || key[a] == 65535) return false;
  switch (keyState(key)) {
    case VoxelState::kFree: return true;
    case VoxelState::kOccupied: return false;
    case VoxelState::kUnknown: return policy_ == UnknownPolicy::kFree && stats_.bounds.contains(p);
  }
  return false;
}

void OccupancyMap::forEachLeaf(const std::function<void(const Vec3&, double, VoxelState)>& fn) const {
  // A map read from the cache and not written since: its leaves are in the bytes.
  const bool unwritten = !overlay_ || (!overlay_->own.load(std::memory_order_acquire) && overlay_->changes.empty());
  if (!tree_ && unwritten && lazy_->forEachLeaf(fn)) return;
  for (auto it = tree().begin_leafs(), end = tree().end_leafs(); it != end; ++it) {
    // Centres in double (getX/Y/Z): the iterator's getCoordinate() is a float point3d, whose
    // rounding moves a voxel face off the grid (0.55f - 0.05 > 0.5), so a caller testing whether
    // a voxel meets a plane on a voxel boundary missed both voxels beside it.
    fn(Vec3(it.getX(), it.getY(), it.getZ()), it.getSize(),
       tree().isNodeOccupied(*it) ? VoxelState::kOccupied : VoxelState::kFree);
  }
}

Status OccupancyMap::setVoxels(const std::vector<Vec3>& points, VoxelState state) {
  return setVoxels(points, state, nullptr);
}

Status OccupancyMap::setVoxels(const std::vector<Vec3>& points, VoxelState state, MapChange* change) {
  std::vector<octomap::OcTreeKey> point_keys(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    if (!allFinite(p) || !keys().coordToKeyChecked(p.x(), p.y(), p.z(), point_keys[i])) {
      std::ostringstream os;
      os << "point " << i << " (" << p.transpose() << ") is outside the map's key range";
      return outOfRange(os.str());
    }
  }
  prepareWrite();
  MapChange local;
  for (const octomap::OcTreeKey& key : point_keys) applyKey(key, state, local);
  finishUpdate();
  if (change) *change = local;
  return {};
}

// One voxel to `state`. Counts are kept incrementally: a whole-tree pass per sensed batch would
// dominate the update. Bounds only grow (a voxel set to unknown leaves them as they were).
void OccupancyMap::applyKey(const octomap::OcTreeKey& key, VoxelState state, MapChange& change) {
  // In an overlay, the voxel's entry and the shared tree's state, each looked up once: the state
  // before is the entry's, else the tree's, and a write back to the tree's state drops the entry.
  const bool in_overlay = overlay_ && !overlay_->own.load(std::memory_order_acquire);
  auto entry = in_overlay ? overlay_->changes.find(key) : decltype(overlay_->changes.end()){};
  const VoxelState shared = in_overlay ? baseState(key) : VoxelState::kUnknown;
  const VoxelState before = !in_overlay ? keyState(key) : entry != overlay_->changes.end() ? entry->second : shared;
  if (before != VoxelState::kUnknown) (before == VoxelState::kOccupied ? stats_.occupied_voxels : stats_.free_voxels) -= 1;
  const double res = keys().getResolution();
  const octomap::point3d c = keys().keyToCoord(key);
  const Vec3 centre(c.x(), c.y(), c.z());
  if (before != state) {
    (state == VoxelState::kOccupied ? change.to_occupied : state == VoxelState::kFree ? change.to_free : change.to_unknown) += 1;
    change.box.extend(centre - Vec3::Constant(0.5 * res));
    change.box.extend(centre + Vec3::Constant(0.5 * res));
  }
  if (in_overlay) {
    if (entry != overlay_->changes.end()) {
      if (state == shared) overlay_->changes.erase(entry);
      else entry->second = state;
    } else if (state != shared) {
      overlay_->changes.emplace(key, state);
    }
  } else {
    writeNode(tree(), key, state);
  }
  if (state == VoxelState::kUnknown) return;
  (state == VoxelState::kOccupied ? stats_.occupied_voxels : stats_.free_voxels) += 1;
  stats_.bounds.extend(centre - Vec3::Constant(0.5 * res));
  stats_.bounds.extend(centre + Vec3::Constant(0.5 * res));
}

void OccupancyMap::finishUpdate() {
  stats_.octree_nodes = overlay_ && !overlay_->own.load(std::memory_order_acquire)
                            ? baseNodes() + overlay_->changes.size()
                            : tree().size();
  setUnknownFromBounds(stats_);
}

StatusOr<MapChange> OccupancyMap::insertRays(const Vec3& origin, const std::vector<Vec3>& returns, double max_range_m) {
  if (!std::isfinite(max_range_m) || max_range_m <= 0.0) {
    std::ostringstream os;
    os << "insertRays: max_range_m = " << max_range_m << " must be a finite number > 0";
    return invalidArgument(os.str());
  }
  octomap::OcTreeKey origin_key;
  if (!allFinite(origin) || !keys().coordToKeyChecked(origin.x(), origin.y(), origin.z(), origin_key)) {
    std::ostringstream os;
    os << "insertRays: the origin (" << origin.transpose() << ") is outside the map's key range";
    return outOfRange(os.str());
  }
  // A navigator inserts a scan every period, mostly an empty one: skip the key ray's buffer
  // (OctoMap zero-fills 100,000 keys for it).
  if (returns.empty()) return MapChange{};
  // Every key first (a refused scan changes nothing), the returns' keys winning over the rays'.
  octomap::KeySet free_keys, hit_keys;
  octomap::KeyRay ray;
  const octomap::point3d o(float(origin.x()), float(origin.y()), float(origin.z()));
  for (std::size_t i = 0; i < returns.size(); ++i) {
    const Vec3& p = returns[i];
    const double d = allFinite(p) ? (p - origin).norm() : 0.0;
    const bool hit = d <= max_range_m;
    const Vec3 end = hit ? p : Vec3(origin + (p - origin) * (max_range_m / d));
    octomap::OcTreeKey end_key;
    if (!allFinite(p) || !keys().coordToKeyChecked(end.x(), end.y(), end.z(), end_key) ||
        !keys().computeRayKeys(o, octomap::point3d(float(end.x()), float(end.y()), float(end.z())), ray)) {
      std::ostringstream os;
      os << "insertRays: return " << i << " (" << p.transpose() << ") is not finite or its ray leaves the map's key range";
      return outOfRange(os.str());
    }
    free_keys.insert(ray.begin(), ray.end());
    if (hit) hit_keys.insert(end_key);
    else free_keys.insert(end_key);
  }
  prepareWrite();
  MapChange change;
  for (const octomap::OcTreeKey& k : free_keys)
    if (!hit_keys.count(k)) applyKey(k, VoxelState::kFree, change);
  for (const octomap::OcTreeKey& k : hit_keys) applyKey(k, VoxelState::kOccupied, change);
  finishUpdate();
  return change;
}

void OccupancyMap::lineOfSight(const Vec3& origin, const std::vector<Vec3>& targets, std::vector<char>& visible,
                               const std::function<bool(const Vec3&)>& opaque) const {
  visible.assign(targets.size(), 0);
  if (!allFinite(origin) || targets.empty()) return;
  octomap::KeyRay ray;  // one per call: its buffer is large
  const octomap::point3d o(float(origin.x()), float(origin.y()), float(origin.z()));
  for (std::size_t i = 0; i < targets.size(); ++i) {
    const Vec3& p = targets[i];
    if (!allFinite(p) || !keys().computeRayKeys(o, octomap::point3d(float(p.x()), float(p.y()), float(p.z())), ray))
      continue;
    bool clear = true;
    for (const octomap::OcTreeKey& k : ray) {
      const octomap::point3d c = keys().keyToCoord(k);
      const Vec3 centre(c.x(), c.y(), c.z());
      if (!isFree(centre) || (opaque && opaque(centre))) {
        clear = false;
        break;
      }
    }
    visible[i] = clear ? 1 : 0;
  }
}

}  // namespace adit::map
