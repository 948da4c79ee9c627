// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// RoadwayGraph: the mine's roadway structure as a graph, the first thing the global planner
/// consults. Nodes are survey stations and junctions; an edge is a piece of roadway between two
/// nodes, with its corridor (an axis polyline at the roadway's mid-height and a radius that holds
/// its whole cross-section). The planner routes start to goal on this graph (A*), then lets OMPL
/// search only inside the corridor of that route, so a 2 km x 1 km district that is 99 % rock is
/// never sampled as a box. The fusion layer reroutes through the same graph.
///
/// Built from the survey's centrelines and junctions when the map came from a survey YAML
/// (fromSurvey: exact), or from the robot's free space itself for maps without a survey (scans,
/// meshes, .bt/.ot; fromFreeSpace: a Reeb graph of geodesic distance, see its comment). Edges can be blocked, by hand or by
/// re-checking their corridors against the map after a change (a roof fall): routing then takes
/// another roadway, or reports at once that start and goal are disconnected.
///
///   StatusOr<RoadwayGraph> g = RoadwayGraph::fromSurvey(survey);
///   g->refreshBlocked(field, /*required_clearance_m=*/0.7);
///   StatusOr<Route> r = g->route(start, goal);
///   if (!r.ok()) std::cerr << r.status().message();  // e.g. "... disconnected: ... blocked"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/survey_network.hpp"
#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::global {

using map::Vec3;
struct FreeSpaceIndex;

struct RoadwayNode {
  Vec3 position = Vec3::Zero();  ///< on the corridor axis (mid-height of the roadway)
  std::string name;              ///< station name, or "junction-N" / "cell-N"
};

struct RoadwayEdge {
  int from = -1, to = -1;        ///< node indices; axis runs from -> to
  std::string roadway;           ///< survey roadway name (the route reports these)
  map::Polyline axis;            ///< corridor axis, at the roadway's mid-height
  double radius_m = 0.0;         ///< corridor radius around the axis: holds the whole section
  double half_height_m = 0.0;    ///< axis height above the floor (0 when unknown)
  double length_m = 0.0;
  double max_slope_deg = 0.0;    ///< steepest axis segment (the floor's slope for survey edges)
  bool blocked = false;
  std::string blocked_reason;
  /// Where along the axis it is blocked [m from `from`]: a robot on the edge can still leave it
  /// on the side away from the blockage. Blocking by hand blocks the whole edge.
  double blocked_from_m = 0.0, blocked_to_m = 0.0;
};

/// A route through the graph from a start to a goal point: the corridor OMPL searches.
struct Route {
  std::vector<int> edges;             ///< graph edges in order (the pieces start/goal sit on included)
  std::vector<std::string> roadways;  ///< roadway names in order, consecutive repeats merged
  map::Polyline axis;                 ///< start, axis points, goal
  std::vector<double> radius_m;       ///< corridor radius per axis segment
  double length_m = 0.0;              ///< along the axis
};

/// Options of the free-space graph (RoadwayGraph::fromFreeSpace).
struct FreeSpaceGraphOptions {
  double slice_m = 1.0;  ///< thickness of the geodesic slices (the graph's resolution along a passage)
  std::uint64_t max_memory_bytes = std::uint64_t(4) << 30;  ///< refuse maps whose graph needs more
  map::ProgressFn progress;                                ///< optional
};

/// What building a free-space graph took.
struct FreeSpaceGraphInfo {
  std::uint64_t voxels = 0;       ///< voxels of the configuration space (clearance >= required)
  std::uint64_t regions = 0;      ///< its connected parts
  std::uint64_t pieces = 0;       ///< slices' connected pieces, before folding branches
  std::uint64_t folded_branches = 0;
  std::uint64_t memory_bytes = 0; ///< kept afterwards (the voxel -> piece locator)
  std::uint64_t peak_bytes = 0;   ///< working memory during the build (estimate)
  double seconds = 0.0;
};

/// What a surveyor checks of a passage: its narrowest clearance along the axis and its width
/// (the median, over axis samples a voxel apart, of the horizontal distance between the ribs
/// measured square to the axis).
struct PassageMeasure {
  double min_clearance_m = 0.0;
  double width_m = 0.0;
};
PassageMeasure measurePassage(const RoadwayEdge& edge, const map::DistanceField& field);

/// Which edges routing may use (e.g. only those a ground robot can climb). Empty = all unblocked.
using EdgeFilter = std::function<bool(const RoadwayEdge&)>;

class RoadwayGraph {
 public:
  /// From a survey: one edge per centreline segment between consecutive stations. A station that
  /// lies on another roadway's segment (within that roadway's half-width), where a gate road
  /// leaves a main, splits that segment into a junction.
  static StatusOr<RoadwayGraph> fromSurvey(const map::SurveyNetwork& survey);

  /// From the free space, for maps without a survey: a roadway graph of the robot's free
  /// configuration space (voxel centres whose clearance is >= `required_clearance_m`, joined
  /// face to face), so two places are joined exactly when the robot can pass between them at
  /// voxel resolution. Each connected part is sliced by geodesic distance from one of its far
  /// ends (breadth-first, two sweeps) into slices of `options.slice_m`; the connected pieces of
  /// each slice are the graph's pieces, and pieces that touch are joined: a Reeb graph of the
  /// geodesic distance, which follows a roadway whatever its width, splits at junctions and
  /// closes every loop of the map. Branches shorter than twice the clearance of the junction they
  /// leave (wall niches, scan noise) are folded into it; chains of pieces become edges named
  /// "passage-N" between junctions and ends, their axes through the pieces' points of largest
  /// clearance, straightened where the line of sight holds. Refuses, before allocating, a map
  /// whose graph would need more than `options.max_memory_bytes`.
  static StatusOr<RoadwayGraph> fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                              double required_clearance_m, const FreeSpaceGraphOptions& options);
  /// The same with default options and slices of `slice_m`.
  static StatusOr<RoadwayGraph> fromFreeSpace(const map::OccupancyMap& map, const map::DistanceField& field,
                                              double required_clearance_m, double slice_m);

  /// A free-space graph's passage cut across in its middle: the centres of the voxels of its
  /// middle piece (a slice of the robot's free space across the passage, which every way along
  /// the passage crosses). Making them rock blocks the passage for this robot, as an operator's
  /// "block roadway" does on a survey. Empty for a survey graph or a passage of one piece.
  std::vector<Vec3> passageSlice(int edge) const;

  /// How the free-space graph was built (all zero for a survey graph).
  const FreeSpaceGraphInfo& freeSpaceInfo() const { return info_; }
  bool fromFreeSpaceMap() const { return free_space_ != nullptr; }

  const std::vector<RoadwayNode>& nodes() const { return nodes_; }
  const std::vector<RoadwayEdge>& edges() const { return edges_; }
  double totalLength() const;
  /// Edges meeting at `node` (a self-loop counts once).
  int degree(int node) const { return int(incident_.at(std::size_t(node)).size()); }
  /// Nodes with a single edge: the roadway ends (dead ends, faces, portals).
  std::vector<int> ends() const;

  /// The two roadway ends farthest apart (straight-line distance); for a graph without
  /// degree-1 nodes (the free-space graph) the ends of its longest shortest path. Nullopt when
  /// there are no two such nodes.
  std::optional<std::pair<int, int>> farthestEnds() const;
  /// A point on the corridor axis `inset_m` in from end node `node` (away from the rock face).
  Vec3 pointNearEnd(int node, double inset_m) const;

  void setBlocked(int edge, bool blocked, const std::string& reason = "blocked by hand");
  /// Re-checks every edge whose corridor meets `window` (all edges when the window is empty):
  /// an edge is blocked when some cross-section along it, sampled every voxel, holds no point of
  /// clearance >= required_clearance_m; it is unblocked when every one does. Returns the number
  /// of edges blocked afterwards.
  int refreshBlocked(const map::DistanceField& field, double required_clearance_m,
                     const map::Aabb& window = map::Aabb());
  /// The cross-section test of a survey graph's edge at axis point `c` (axis direction `t`, the
  /// roadway's `radius`): true when the robot can pass there. The default is a point of the
  /// section with clearance >= the required; a ground robot must stand on the section's floor.
  using SectionTest = std::function<bool(const Vec3& c, const Vec3& t, double radius)>;
  int refreshBlocked(const map::DistanceField& field, double required_clearance_m, const map::Aabb& window,
                     const SectionTest& section_test);

  /// A* over the unblocked edges that pass `filter`, from the edge nearest to `start` (whose
  /// corridor holds it) to the one nearest to `goal`. Start and goal may lie on a blocked edge:
  /// they leave it on the side away from the blockage. Errors: kNotFound when start or goal lies
  /// in no corridor, kFailedPrecondition when they are disconnected (the message names the
  /// blocked edges that would have connected them).
  StatusOr<Route> route(const Vec3& start, const Vec3& goal, const EdgeFilter& filter = {}) const;

  int addNode(const Vec3& position, const std::string& name);
  /// Adds an edge along `axis` (first point at node `from`, last at node `to`).
  int addEdge(int from, int to, const std::string& roadway, map::Polyline axis, double radius_m,
              double half_height_m);

 private:
  struct Attachment {
    int edge = -1;
    std::size_t segment = 0;
    Vec3 point = Vec3::Zero();
    double distance = 0.0;
  };
  int farthestAlongGraph(int from) const;
  StatusOr<Attachment> attach(const Vec3& p, const char* what, const EdgeFilter& usable) const;
  std::vector<RoadwayNode> nodes_;
  std::vector<RoadwayEdge> edges_;
  std::vector<std::vector<int>> incident_;  ///< edges per node
  std::shared_ptr<const FreeSpaceIndex> free_space_;  ///< voxel locator of a free-space graph
  FreeSpaceGraphInfo info_;
  StatusOr<Attachment> attachByVoxel(const Vec3& p, const EdgeFilter& usable) const;
  bool refreshFreeSpaceEdge(int edge, const map::DistanceField& field, double required_clearance_m);
};

}  // namespace adit::global
