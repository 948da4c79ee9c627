// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Pillar fields: the clutter of the BARN benchmark (Perille et al., SSRR 2020) in a roadway. A
// grid of square cells is filled at random and smoothed by a cellular automaton (BARN's recipe);
// every filled cell becomes a pillar of whole voxels from the floor to the roof of a low slab.
// The independent oracle is a breadth-first search over the cells a disc fits in.
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::test {

struct PillarFieldSpec {
  std::uint64_t seed = 1;
  int rows = 30;            ///< across the roadway (its width is rows x cell)
  int cols = 80;            ///< along it (its length is cols x cell)
  int first_col = 14;       ///< the random field occupies columns [first_col, last_col)
  int last_col = 66;
  double cell_m = 0.15;     ///< cell size and voxel size
  double height_m = 1.95;   ///< the slab's height, floor to roof
  double fill = 0.12;       ///< initial fill probability
  int smoothing = 2;        ///< automaton passes
  int fill_threshold = 5;   ///< an empty cell with at least this many filled neighbours fills
  int clear_threshold = 1;  ///< a filled cell with at most this many filled neighbours clears
};

struct PillarField {
  PillarFieldSpec spec;
  map::SurveyNetwork survey;
  std::unique_ptr<map::OccupancyMap> map;
  std::unique_ptr<map::DistanceField> field;
  std::vector<char> pillar;  ///< rows x cols
  map::Vec3 origin;          ///< centre of cell (0, 0) on the floor
  double floor_z = 0.0;

  bool at(int r, int c) const { return pillar[std::size_t(r * spec.cols + c)] != 0; }
  map::Vec3 cellCentre(int r, int c, double z) const {
    return map::Vec3(origin.x() + c * spec.cell_m, origin.y() + r * spec.cell_m, z);
  }
  /// Filled cells over the random field's cells.
  double filledFraction() const;
};

/// Builds the field (fails the current test on error; the result is then incomplete).
std::unique_ptr<PillarField> makePillarField(const PillarFieldSpec& spec);

/// The oracle: 4-connected breadth-first search over the cells where a disc of `radius` keeps
/// `margin` from every pillar and rib (the exact field at the body's height), from any cell of
/// column `from_col` to any of `to_col`. The cell path, or empty when there is none.
std::vector<std::pair<int, int>> gridPassage(const PillarField& f, double radius, double margin, int from_col,
                                             int to_col);
/// The same search between two given cells (empty when either does not fit or none joins them).
std::vector<std::pair<int, int>> gridPassage(const PillarField& f, double radius, double margin,
                                             std::pair<int, int> from, std::pair<int, int> to);

/// Length of the cell path's centreline after string pulling against the oracle's own test (the
/// shortest path a disc of `radius` + `margin` can follow, up to the grid's resolution).
double pulledLength(const PillarField& f, const std::vector<std::pair<int, int>>& cells, double radius, double margin);

}  // namespace adit::test
