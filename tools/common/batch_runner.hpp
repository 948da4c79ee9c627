// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The machinery shared by `adit simulate --batch` and `adit campaign run|merge` and
/// `adit simulate --replay`: the base scenario of a batch (the district rescue robot on a survey
/// map), the map, survey and true world loaded once, and runBatchWorkers(), which runs a list of
/// scenario indices (adit/sim/batch.hpp) on forked worker processes. Workers are processes,
/// not threads, because OMPL's seed is process-global; they are forked after the map is loaded
/// so they share it copy-on-write. A run's row depends only on (seed, index, generator), never
/// on the worker that ran it, so any split of the indices gives the same rows.
///
/// A campaign's identity (sim::CampaignIdentity, adit/sim/campaign.hpp) is written into every
/// shard's JSON and is enough to rebuild any scenario (replayScenario()).
///
///   ADIT_ASSIGN_OR_RETURN(BatchSetup setup, loadBatchSetup("", "maps/district.yaml"));
///   ADIT_ASSIGN_OR_RETURN(auto rows, runBatchWorkers(setup, params, {0, 4, 8}, 2, bar));

#include <nlohmann/json.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "adit/map/survey_network.hpp"
#include "adit/sim/batch.hpp"
#include "adit/sim/scenario.hpp"
#include "adit/sim/simulator.hpp"
#include "adit/status.hpp"
#include "adit/sim/campaign.hpp"
#include "common/progress.hpp"

namespace adit::tools {

/// What every run of a batch shares: the base scenario (robot, method, params), the roadways the
/// starts and goals are drawn on (a survey's, or the free-space graph's of any other map), and
/// the true world.
struct BatchSetup {
  sim::Scenario base;
  sim::BatchRoadways roadways;
  /// The robot's map at t = 0, loaded once; every run starts from a deep copy of it. The true
  /// world borrows its map and field: nothing writes them (a World keeps them on the heap, so the
  /// borrow survives a move).
  map::World believed;
  sim::Environment truth;
};

/// The base scenario is `scenario_file` when given (its map replaced by `map` when both are
/// given), else the district rescue robot (radius 0.4 m, v_max 1 m/s, sensor 8 m, tian2016) on
/// `map`. A map without a survey (a scan or mesh converted to .bt, a .bt/.ot) has its roadways
/// drawn from the free-space roadway graph for the base robot. Errors name the file.
StatusOr<BatchSetup> loadBatchSetup(const std::string& scenario_file, const std::string& map, bool no_cache = false);

/// Runs scenario `indices` of the batch `params` on min(jobs, indices.size()) forked workers,
/// feeding `bar` (stage `stage`). The rows come back in the order of `indices`. A scenario that
/// cannot be generated or simulated is a row with outcome "error"; a worker that dies loses its
/// rows and the call fails (internal error) naming the first lost index.
StatusOr<std::vector<sim::BatchRunResult>> runBatchWorkers(const BatchSetup& setup,
                                                                const sim::BatchParams& params,
                                                                const std::vector<int>& indices, int jobs,
                                                                ProgressBar& bar, const char* stage = "batch");

/// Scenario INDEX of a recorded campaign, from "CAMPAIGN:INDEX" where CAMPAIGN is a campaign
/// directory (any shard-K-of-M.json in it) or a shard JSON. Checks that the map has not changed
/// since (content hash). `map_override`, if given, is the map's file instead of the recorded path
/// (a campaign run elsewhere; its content hash must still match). Errors: bad spec, no shard JSON,
/// index outside 0..N-1, a relative map path not found from here, changed map.
StatusOr<sim::Scenario> replayScenario(const std::string& spec, const std::string& map_override = "");

}  // namespace adit::tools
