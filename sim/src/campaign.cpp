// SPDX-License-Identifier: BSD-3-Clause
#include "adit/sim/campaign.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <unordered_set>

namespace adit::sim {

namespace {

using Json = nlohmann::ordered_json;

const char* const kOutcomes[] = {"arrived", "collision", "stuck", "timeout", "no_route", "hit_by_fall", "hit_by_mover", "error"};

nlohmann::ordered_json range(double lo, double hi) { return nlohmann::ordered_json::array({lo, hi}); }

// A JSON integer in [lo, hi], whatever its stored type (nlohmann keeps non-negative integers as
// unsigned): a float, a string or a value beyond the range is refused, never cast.
StatusOr<long long> jsonInteger(const nlohmann::json& c, const char* key, long long lo, long long hi,
                                const std::string& where) {
  if (!c.contains(key)) return invalidArgument(where + "." + key + ": missing");
  const nlohmann::json& v = c[key];
  long long x = 0;
  if (v.is_number_unsigned()) {
    const std::uint64_t u = v.get<std::uint64_t>();
    if (u > std::uint64_t(std::numeric_limits<long long>::max()))
      return invalidArgument(where + "." + key + ": " + std::to_string(u) + " is out of range");
    x = static_cast<long long>(u);
  } else if (v.is_number_integer()) {
    x = v.get<long long>();
  } else {
    return invalidArgument(where + "." + key + ": expected an integer, got " + v.dump());
  }
  if (x < lo || x > hi)
    return invalidArgument(where + "." + key + ": " + std::to_string(x) + " is outside " + std::to_string(lo) + ".." +
                           std::to_string(hi));
  return x;
}

// a += b, refused (naming the sum) instead of wrapping.
Status checkedAdd(long long& a, long long b, const char* what) {
  long long r = 0;
  if (__builtin_add_overflow(a, b, &r)) return invalidArgument(std::string("the sum ") + what + " overflows");
  a = r;
  return Status();
}

std::size_t stepBucket(double us) {
  return std::size_t(std::upper_bound(kStepEdgesUs.begin(), kStepEdgesUs.end(), us) - kStepEdgesUs.begin());
}

// "[lo, hi)" of the fixed-width bucket holding v (e.g. width 10: "20-30").
std::string bucketLabel(double v, double width, int decimals) {
  const double lo = std::floor(v / width + 1e-9) * width;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f-%.*f", decimals, lo, decimals, lo + width);
  return buf;
}

// The value at `ptr` in `j`, shown short, or "nothing".
std::string shown(const nlohmann::json& j, const nlohmann::json::json_pointer& ptr) {
  if (!j.contains(ptr)) return "nothing";
  std::string s = j.at(ptr).dump();
  if (s.size() > 80) s = s.substr(0, 77) + "...";
  return s;
}

}  // namespace

nlohmann::ordered_json campaignIdentityJson(const CampaignIdentity& id) {
  const sim::BatchParams& g = id.generator;
  nlohmann::ordered_json gen;
  gen["separation"] = range(g.min_separation_m, g.max_separation_m);
  gen["max_moving_obstacles"] = g.max_moving_obstacles;
  gen["vehicle_speed"] = range(g.vehicle_speed_min_mps, g.vehicle_speed_max_mps);
  gen["vehicle_radius"] = g.vehicle_radius_m;
  gen["roof_fall"] = {{"probability", g.roof_fall_probability}, {"radius", g.roof_fall_radius_m}};
  gen["robot_radius"] = range(g.robot_radius_min_m, g.robot_radius_max_m);
  gen["robot_speed"] = range(g.robot_speed_min_mps, g.robot_speed_max_mps);
  gen["t_max"] = g.t_max_s;
  gen["near_rock_goals"] = g.near_rock_goal_share;
  if (!g.robot_json.empty()) gen["robot"] = nlohmann::ordered_json::parse(g.robot_json);
  nlohmann::ordered_json j;
  j["map"] = id.map;
  j["map_hash"] = id.map_hash;
  j["seed"] = id.seed;
  j["scenarios"] = id.scenarios;
  j["shards"] = id.shards;
  j["generator"] = gen;
  j["adit_version"] = id.adit_version;
  j["adit_commit"] = id.adit_commit;
  return j;
}

StatusOr<CampaignIdentity> campaignIdentityFromJson(const nlohmann::json& j, const std::string& file) {
  if (!j.is_object() || !j.contains("campaign") || !j["campaign"].is_object())
    return invalidArgument(file + ": not a campaign shard (no \"campaign\" object)");
  const nlohmann::json& c = j["campaign"];
  const std::string where = file + ": campaign";
  CampaignIdentity id;
  for (const char* key : {"map", "map_hash"})
    if (!c.contains(key) || !c[key].is_string()) return invalidArgument(where + "." + key + ": expected a string");
  id.map = c["map"].get<std::string>();
  id.map_hash = c["map_hash"].get<std::string>();
  if (!c.contains("seed") || !c["seed"].is_number_unsigned())
    return invalidArgument(where + ".seed: expected an integer in 0..2^64-1");
  id.seed = c["seed"].get<std::uint64_t>();
  ADIT_ASSIGN_OR_RETURN(const long long n, jsonInteger(c, "scenarios", 1, std::numeric_limits<int>::max(), where));
  ADIT_ASSIGN_OR_RETURN(const long long m, jsonInteger(c, "shards", 1, n, where));
  id.scenarios = int(n);
  id.shards = int(m);
  for (const char* key : {"adit_version", "adit_commit"})
    if (c.contains(key) && !c[key].is_string()) return invalidArgument(where + "." + key + ": expected a string");
  id.adit_version = c.value("adit_version", std::string());
  id.adit_commit = c.value("adit_commit", std::string());
  if (!c.contains("generator") || !c["generator"].is_object())
    return invalidArgument(where + ".generator: expected an object");
  // JSON is YAML: the generator object is read by the generator's own reader.
  ADIT_ASSIGN_OR_RETURN(id.generator, sim::parseBatchParams(c["generator"].dump(), where + ".generator"));
  id.generator.seed = id.seed;
  return id;
}

std::vector<std::string> campaignIdentityDifferences(const CampaignIdentity& a, const CampaignIdentity& b) {
  std::vector<std::string> d;
  if (a.map_hash != b.map_hash) d.push_back("map content (" + b.map_hash + " vs " + a.map_hash + ")");
  if (a.seed != b.seed) d.push_back("seed (" + std::to_string(b.seed) + " vs " + std::to_string(a.seed) + ")");
  if (a.scenarios != b.scenarios)
    d.push_back("scenarios (" + std::to_string(b.scenarios) + " vs " + std::to_string(a.scenarios) + ")");
  if (a.shards != b.shards) d.push_back("shards (" + std::to_string(b.shards) + " vs " + std::to_string(a.shards) + ")");
  if (campaignIdentityJson(a)["generator"] != campaignIdentityJson(b)["generator"]) d.push_back("generator ranges");
  if (a.adit_version != b.adit_version) d.push_back("adit version (" + b.adit_version + " vs " + a.adit_version + ")");
  return d;
}

std::string shardName(int k, int m, const char* ext) {
  return "shard-" + std::to_string(k) + "-of-" + std::to_string(m) + ext;
}

long long shardScenarioCount(int k, int m, int n) { return (static_cast<long long>(n) - k + m - 1) / m; }

CampaignStats::CampaignStats() {
  for (const char* o : kOutcomes) outcomes[o] = 0;
}

Status CampaignStats::add(const sim::BatchRunResult& r) {
  ++scenarios;
  ++outcomes[r.outcome];
  if (r.end_cause != sim::EndCause::kNone) ++end_causes[r.outcome][sim::endCauseName(r.end_cause)];
  if (r.separation_m > 0.0) {
    ++by_feature["vehicles"][std::to_string(r.vehicles)][r.outcome];
    ++by_feature["roof_fall"][r.roof_fall ? "yes" : "no"][r.outcome];
    ++by_feature["separation_m"][bucketLabel(r.separation_m, 10.0, 0)][r.outcome];
    ++by_feature["robot_radius_m"][bucketLabel(r.robot_radius_m, 0.05, 2)][r.outcome];
    ++by_feature["robot_speed_mps"][bucketLabel(r.robot_speed_mps, 0.1, 1)][r.outcome];
    ++by_feature["roadway_width_m"][bucketLabel(r.roadway_width_m, 0.5, 1)][r.outcome];
  }
  ADIT_RETURN_IF_ERROR(checkedAdd(replans, r.replans, "replans"));
  runs_with_replans += r.replans > 0;
  if (r.outcome == "error") return Status();
  // Rows come from sim::parseBatchCsvRow(): lengths and times are finite and below 1e9, so
  // one row's millimetres fit; their sum is what is checked.
  ADIT_RETURN_IF_ERROR(checkedAdd(path_length_mm, std::llround(r.path_length_m * 1000.0), "path_length_mm_sum"));
  if (std::isfinite(r.min_clearance_m))
    min_clearance_m = std::min(min_clearance_m.value_or(r.min_clearance_m), r.min_clearance_m);
  ++step_p50[stepBucket(r.step_p50_us)];
  ++step_p99[stepBucket(r.step_p99_us)];
  if (r.outcome != "arrived") return Status();
  if (std::isfinite(r.arrival_time_s))
    ADIT_RETURN_IF_ERROR(checkedAdd(arrival_time_ms, std::llround(r.arrival_time_s * 1000.0), "arrival_time_ms_sum"));
  collisions_among_arrivals += r.collisions > 0;
  arrivals_beyond_tolerance += !(r.final_goal_distance_m <= r.arrival_tolerance_m);
  return Status();
}

Status CampaignStats::add(const CampaignStats& o) {
  ADIT_RETURN_IF_ERROR(checkedAdd(scenarios, o.scenarios, "scenarios"));
  for (const auto& [k, v] : o.outcomes) ADIT_RETURN_IF_ERROR(checkedAdd(outcomes[k], v, "outcomes"));
  ADIT_RETURN_IF_ERROR(checkedAdd(collisions_among_arrivals, o.collisions_among_arrivals, "collisions_among_arrivals"));
  ADIT_RETURN_IF_ERROR(checkedAdd(arrivals_beyond_tolerance, o.arrivals_beyond_tolerance, "arrivals_beyond_tolerance"));
  ADIT_RETURN_IF_ERROR(checkedAdd(replans, o.replans, "replans"));
  ADIT_RETURN_IF_ERROR(checkedAdd(runs_with_replans, o.runs_with_replans, "runs_with_replans"));
  ADIT_RETURN_IF_ERROR(checkedAdd(arrival_time_ms, o.arrival_time_ms, "arrival_time_ms_sum"));
  ADIT_RETURN_IF_ERROR(checkedAdd(path_length_mm, o.path_length_mm, "path_length_mm_sum"));
  if (o.min_clearance_m) min_clearance_m = std::min(min_clearance_m.value_or(*o.min_clearance_m), *o.min_clearance_m);
  for (const auto& [outcome, causes] : o.end_causes)
    for (const auto& [cause, n] : causes) ADIT_RETURN_IF_ERROR(checkedAdd(end_causes[outcome][cause], n, "end_causes"));
  for (const auto& [feature, buckets] : o.by_feature)
    for (const auto& [label, counts] : buckets)
      for (const auto& [outcome, n] : counts)
        ADIT_RETURN_IF_ERROR(checkedAdd(by_feature[feature][label][outcome], n, "outcomes_by_feature"));
  for (std::size_t k = 0; k < step_p50.size(); ++k) {
    ADIT_RETURN_IF_ERROR(checkedAdd(step_p50[k], o.step_p50[k], "step_time_us.p50_per_run"));
    ADIT_RETURN_IF_ERROR(checkedAdd(step_p99[k], o.step_p99[k], "step_time_us.p99_per_run"));
  }
  return Status();
}

nlohmann::ordered_json CampaignStats::toJson() const {
  Json c;
  c["scenarios"] = scenarios;
  c["outcomes"] = Json(outcomes);
  c["collisions_among_arrivals"] = collisions_among_arrivals;
  c["arrivals_beyond_tolerance"] = arrivals_beyond_tolerance;
  c["replans"] = replans;
  c["runs_with_replans"] = runs_with_replans;
  c["arrival_time_ms_sum"] = arrival_time_ms;
  c["path_length_mm_sum"] = path_length_mm;
  c["min_clearance"] = min_clearance_m ? Json(*min_clearance_m) : Json(nullptr);
  c["outcomes_by_feature"] = Json(by_feature);
  c["end_causes"] = Json(end_causes);
  Json t = {{"bucket_upper_edges", kStepEdgesUs}, {"p50_per_run", step_p50}, {"p99_per_run", step_p99}};
  return {{"counts", c}, {"step_time_us", t}};
}

bool isFailure(const sim::BatchRunResult& r) { return r.outcome != "arrived" || r.collisions > 0; }

nlohmann::ordered_json failureEntry(const sim::BatchRunResult& r) {
  nlohmann::ordered_json e = {{"index", r.index}, {"seed", r.seed}, {"outcome", r.outcome}, {"collisions", r.collisions}};
  if (r.end_cause != sim::EndCause::kNone) e["end_cause"] = sim::endCauseName(r.end_cause);
  e["message"] = r.message;
  return e;
}

std::size_t maxShardCsvBytes(long long rows) { return std::size_t(rows + 1) * 1024; }

StatusOr<ShardRows> readShardRows(const std::string& csv_text, const std::string& csv_path, const CampaignIdentity& id,
                                  int k) {
  const long long expected = shardScenarioCount(k, id.shards, id.scenarios);
  if (csv_text.size() > maxShardCsvBytes(expected))
    return invalidArgument(csv_path + ": " + std::to_string(csv_text.size()) + " bytes, more than " +
                           std::to_string(expected) + " rows can take");
  ShardRows out;
  // The rows seen so far, not a flag per scenario of the shard: a JSON may claim 2^31 scenarios,
  // and memory must follow what the CSV holds, not what the JSON says.
  std::unordered_set<int> seen;
  std::size_t from = 0;
  long long line_no = 0;
  while (from < csv_text.size()) {
    std::size_t nl = csv_text.find('\n', from);
    if (nl == std::string::npos) nl = csv_text.size();
    std::string_view line(csv_text.data() + from, nl - from);
    from = nl + 1;
    ++line_no;
    const std::string at = csv_path + ":" + std::to_string(line_no) + ": ";
    if (line_no == 1) {
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (line != sim::batchCsvHeader())
        return invalidArgument(at + "not this adit's header (" + sim::batchCsvHeader() + ")");
      continue;
    }
    if (line.empty()) return invalidArgument(at + "an empty line");
    if (static_cast<long long>(out.rows.size()) == expected)
      return invalidArgument(at + "more rows than the " + std::to_string(expected) + " of shard " + std::to_string(k) +
                             " of " + std::to_string(id.shards));
    StatusOr<sim::BatchRunResult> r = sim::parseBatchCsvRow(line);
    if (!r.ok()) return invalidArgument(at + r.status().message());
    if (r->index >= id.scenarios || r->index % id.shards != k)
      return invalidArgument(at + "scenario " + std::to_string(r->index) + " is not one of shard " + std::to_string(k) +
                             " of " + std::to_string(id.shards) + " (i mod " + std::to_string(id.shards) + " == " +
                             std::to_string(k) + ", i < " + std::to_string(id.scenarios) + ")");
    if (!seen.insert(r->index).second) return invalidArgument(at + "scenario " + std::to_string(r->index) + " again");
    if (const std::uint64_t s = sim::batchRunSeed(id.seed, r->index); r->seed != s)
      return invalidArgument(at + "scenario " + std::to_string(r->index) + " has seed " + std::to_string(r->seed) +
                             "; campaign seed " + std::to_string(id.seed) + " gives it " + std::to_string(s));
    if (Status s = out.stats.add(*r); !s.ok()) return invalidArgument(at + s.message());
    out.lines.emplace_back(line.substr(0, line.size() - (!line.empty() && line.back() == '\r')));
    out.rows.push_back(std::move(*r));
  }
  if (line_no == 0) return invalidArgument(csv_path + ": empty (no header)");
  if (static_cast<long long>(out.rows.size()) != expected)
    return invalidArgument(csv_path + ": " + std::to_string(out.rows.size()) + " rows, shard " + std::to_string(k) +
                           " of " + std::to_string(id.shards) + " has " + std::to_string(expected));
  return out;
}

StatusOr<std::vector<nlohmann::ordered_json>> checkShardSummary(const nlohmann::json& shard_json,
                                                                const ShardRows& rows, const std::string& json_path) {
  // The statistics: the rows' recomputation must be what the file says, field for field.
  const nlohmann::json claimed = shard_json.contains("stats") ? shard_json["stats"] : nlohmann::json();
  const nlohmann::json computed = nlohmann::json::parse(rows.stats.toJson().dump());
  const nlohmann::json patch = nlohmann::json::diff(computed, claimed);
  if (!patch.empty()) {
    const nlohmann::json::json_pointer at(patch[0]["path"].get<std::string>());
    return invalidArgument(json_path + ": /stats" + at.to_string() + " is " + shown(claimed, at) + ", its rows give " +
                           shown(computed, at));
  }
  // The failure list: one entry per failed row, in row order, with the row's index, seed,
  // outcome and collisions; the message (not in the CSV) must be a string.
  if (!shard_json.contains("failures") || !shard_json["failures"].is_array())
    return invalidArgument(json_path + ": /failures: expected an array");
  const nlohmann::json& listed = shard_json["failures"];
  std::vector<nlohmann::ordered_json> out;
  std::size_t i = 0;
  for (const sim::BatchRunResult& r : rows.rows) {
    if (!isFailure(r)) continue;
    const std::string where = json_path + ": /failures/" + std::to_string(i);
    if (i >= listed.size())
      return invalidArgument(where + ": missing (scenario " + std::to_string(r.index) + " failed: " + r.outcome + ")");
    const nlohmann::json& e = listed[i++];
    if (!e.is_object()) return invalidArgument(where + ": expected an object");
    nlohmann::ordered_json expect = failureEntry(r);
    for (const char* key : {"index", "seed", "outcome", "collisions", "end_cause"}) {
      const bool want = expect.contains(key), has = e.contains(key);
      if (!want && !has) continue;
      if (!want || !has || e[key] != nlohmann::json::parse(expect[key].dump()))
        return invalidArgument(where + "/" + key + " is " + (has ? e[key].dump() : "nothing") + ", its rows give " +
                               (want ? expect[key].dump() : "nothing"));
    }
    if (!e.contains("message") || !e["message"].is_string() || e["message"].get_ref<const std::string&>().size() > 4096)
      return invalidArgument(where + "/message: expected a string of at most 4096 bytes");
    expect["message"] = e["message"].get<std::string>();
    out.push_back(std::move(expect));
  }
  if (i != listed.size())
    return invalidArgument(json_path + ": /failures has " + std::to_string(listed.size()) + " entries, its rows give " +
                           std::to_string(i));
  return out;
}

}  // namespace adit::sim
