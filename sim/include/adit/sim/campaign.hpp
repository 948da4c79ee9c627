// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The campaign model: a campaign's identity, its statistics that merge by exact addition, and a
/// shard's files and why `adit campaign merge` can trust them. Shard K of M writes
/// `shard-K-of-M.csv` (a row per scenario, sim::batchCsvRow()) and `shard-K-of-M.json` (the
/// campaign's identity, the SHA-256 of the CSV's bytes, the statistics and the failures). Merge
/// believes none of the JSON's numbers: it checks the CSV against the recorded digest, parses
/// every row (sim::parseBatchCsvRow()), checks that each row belongs to this shard of this
/// campaign (its index is one of shard K's, once, and its seed is the one the campaign seed gives
/// that index), recomputes the statistics and the failure list from the rows, and refuses a shard
/// whose JSON says anything else, naming the file and the field. Sums are checked for overflow,
/// never wrapped.
///
/// The digest makes edits evident, not impossible: whoever edits both files and recomputes the
/// digest is caught only by the seed check and by a re-run of the shard (the rows, less their
/// step times, are reproducible).
///
///   ADIT_ASSIGN_OR_RETURN(ShardRows rows, readShardRows(csv_text, csv_path, id, k));
///   ADIT_ASSIGN_OR_RETURN(auto failures, checkShardSummary(shard_json, rows, json_path));

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "adit/sim/batch.hpp"
#include "adit/status.hpp"

namespace adit::sim {

/// Which campaign a shard belongs to.
struct CampaignIdentity {
  std::string map;       ///< the map path as given (informative: shards compare by map_hash)
  std::string map_hash;  ///< map::fileContentHash() of the map file
  std::uint64_t seed = 1;
  int scenarios = 0;     ///< N: scenario indices 0..N-1
  int shards = 1;        ///< M
  sim::BatchParams generator;
  std::string adit_version;
  std::string adit_commit;  ///< `git describe` of the build (recorded, not compared: a re-run shard may be a rebuild)
};

/// {"map", "map_hash", "seed", "scenarios", "shards", "generator": {...}, "adit_version",
/// "adit_commit"}; the generator object uses the keys of the generator YAML
/// (sim::parseBatchParams).
nlohmann::ordered_json campaignIdentityJson(const CampaignIdentity& id);
/// The inverse; errors name `file` and the missing or bad field. Integers must be integers in
/// range (a seed is a uint64, N and M ints with 1 <= M <= N), never a float or a wrapped value.
StatusOr<CampaignIdentity> campaignIdentityFromJson(const nlohmann::json& j, const std::string& file);
/// What differs between two identities that makes their shards parts of different campaigns, one
/// phrase per field ("seed (2 vs 1)", b's value first); empty when they are one campaign. The map
/// path may differ between machines, its content may not; the commit is recorded, not compared.
std::vector<std::string> campaignIdentityDifferences(const CampaignIdentity& a, const CampaignIdentity& b);

/// "shard-K-of-M" + ext.
std::string shardName(int k, int m, const char* ext);
/// How many of N scenarios shard K of M runs (the indices i with i mod M == K).
long long shardScenarioCount(int k, int m, int n);

// Fixed step-time buckets [us]: bucket k holds [edge k-1, edge k); the last is [1e5, inf).
inline constexpr std::array<double, 16> kStepEdgesUs = {1,   2,    5,    10,   20,    50,    100,   200,
                                                        500, 1000, 2000, 5000, 10000, 20000, 50000, 100000};

/// Statistics that merge by exact addition (and a minimum). Times and lengths are summed in
/// integer milliseconds / millimetres so that sums do not depend on the order.
struct CampaignStats {
  std::map<std::string, long long> outcomes;
  long long scenarios = 0, collisions_among_arrivals = 0, arrivals_beyond_tolerance = 0;
  long long replans = 0, runs_with_replans = 0, arrival_time_ms = 0, path_length_mm = 0;
  std::optional<double> min_clearance_m;
  std::array<long long, kStepEdgesUs.size() + 1> step_p50{}, step_p99{};
  /// Timeout and stuck runs by sim::EndCause: outcome -> cause name -> count.
  std::map<std::string, std::map<std::string, long long>> end_causes;
  /// Outcome counts by scenario feature: feature -> bucket label -> outcome -> count.
  std::map<std::string, std::map<std::string, std::map<std::string, long long>>> by_feature;

  CampaignStats();
  /// Adds one row. Errors: a sum would overflow (naming it).
  Status add(const sim::BatchRunResult& r);
  /// Adds another shard's statistics. Errors: a sum would overflow (naming it).
  Status add(const CampaignStats& o);
  /// {"counts": {...}, "step_time_us": {...}}: "counts" depends only on the campaign,
  /// "step_time_us" is measured (wall clock).
  nlohmann::ordered_json toJson() const;
};

/// A failure-list entry: index, seed, outcome, collisions, message.
bool isFailure(const sim::BatchRunResult& r);
nlohmann::ordered_json failureEntry(const sim::BatchRunResult& r);

/// A shard's CSV, parsed and checked row by row.
struct ShardRows {
  std::vector<sim::BatchRunResult> rows;  ///< in file order
  std::vector<std::string> lines;            ///< the rows' text, as in the file
  CampaignStats stats;                       ///< recomputed from `rows`
};

/// The largest shard CSV readShardRows() accepts for `rows` rows, in bytes (a row is under 400).
std::size_t maxShardCsvBytes(long long rows);

/// Parses and checks the CSV text of shard `k` of campaign `id`: the header is
/// sim::batchCsvHeader(); every row parses; its index is one of shard k's, appears once, and
/// its seed is sim::batchRunSeed(id.seed, index); there are exactly shardScenarioCount() rows.
/// Errors name `csv_path`, the line and the column.
StatusOr<ShardRows> readShardRows(const std::string& csv_text, const std::string& csv_path, const CampaignIdentity& id,
                                  int k);

/// Checks a shard JSON's "stats" and "failures" against what its rows give. Errors name
/// `json_path` and the first field that disagrees (as a JSON pointer, e.g.
/// /stats/counts/outcomes/arrived) with both values; a malformed failure entry names its
/// position and field. Returns the failure entries (with the JSON's messages), in row order.
StatusOr<std::vector<nlohmann::ordered_json>> checkShardSummary(const nlohmann::json& shard_json,
                                                                const ShardRows& rows, const std::string& json_path);

}  // namespace adit::sim
