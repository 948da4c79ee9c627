// SPDX-License-Identifier: BSD-3-Clause
// `adit campaign run|merge` (issue 9): a validation campaign of N randomized navigated scenarios
// (adit/fusion/batch.hpp) split into M shards that run anywhere (one laptop, a Slurm array) and
// merge exactly. Shard K runs the indices {i : i mod M == K} (strided, so slow and fast parts of
// the index range spread evenly over the shards) and writes DIR/shard-K-of-M.csv (a row per
// scenario) and then DIR/shard-K-of-M.json (the campaign's identity and mergeable statistics:
// integer counts, integer sums, fixed-bucket histograms). Both are written atomically; the JSON
// last, so a shard with a JSON is complete. Merging adds integers: the result does not depend
// on the order of the shards, nor on M or --jobs.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>

#include "adit/fusion/batch.hpp"
#include "adit/map/map_io.hpp"
#include "adit_commit.hpp"
#include "common/animation_page.hpp"
#include "common/batch_runner.hpp"
#include "common/cli.hpp"
#include "common/progress.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using Json = nlohmann::ordered_json;

struct CampaignArgs {
  std::string map, generator, shard = "0/1", out;
  int scenarios = 0, jobs = 1;
  std::uint64_t seed = 1;
  double t_max = 0.0, max_separation = 0.0;  // the generator's unless given
  bool t_max_given = false, max_separation_given = false;
  bool quiet = false;
  // merge
  std::vector<std::string> inputs;
  std::string report, csv, html;
};

const char* const kOutcomes[] = {"arrived", "collision", "stuck", "timeout", "no_route", "error"};
// Fixed step-time buckets [us]: bucket k holds [edge k-1, edge k); the last is [1e5, inf).
constexpr std::array<double, 16> kStepEdgesUs = {1,   2,    5,    10,   20,    50,    100,   200,
                                                 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000};

// Statistics that merge by addition (and min for the clearance: exact too). Times and lengths
// are summed in integer milliseconds / millimetres so that sums do not depend on the order.
struct Stats {
  std::map<std::string, long long> outcomes;
  long long scenarios = 0, collisions_among_arrivals = 0, arrivals_beyond_tolerance = 0;
  long long replans = 0, runs_with_replans = 0, arrival_time_ms = 0, path_length_mm = 0;
  std::optional<double> min_clearance_m;
  std::array<long long, kStepEdgesUs.size() + 1> step_p50{}, step_p99{};
  // Outcome counts by scenario feature: feature -> bucket label -> outcome -> count.
  std::map<std::string, std::map<std::string, std::map<std::string, long long>>> by_feature;

  Stats() {
    for (const char* o : kOutcomes) outcomes[o] = 0;
  }
  static std::size_t bucket(double us) {
    return std::size_t(std::upper_bound(kStepEdgesUs.begin(), kStepEdgesUs.end(), us) - kStepEdgesUs.begin());
  }
  // "[lo, hi)" of the fixed-width bucket holding v (e.g. width 10: "20-30").
  static std::string bucketLabel(double v, double width, int decimals) {
    const double lo = std::floor(v / width + 1e-9) * width;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f-%.*f", decimals, lo, decimals, lo + width);
    return buf;
  }
  void add(const fusion::BatchRunResult& r) {
    ++scenarios;
    ++outcomes[r.outcome];
    if (r.separation_m > 0.0) {
      ++by_feature["vehicles"][std::to_string(r.vehicles)][r.outcome];
      ++by_feature["roof_fall"][r.roof_fall ? "yes" : "no"][r.outcome];
      ++by_feature["separation_m"][bucketLabel(r.separation_m, 10.0, 0)][r.outcome];
      ++by_feature["robot_radius_m"][bucketLabel(r.robot_radius_m, 0.05, 2)][r.outcome];
      ++by_feature["robot_speed_mps"][bucketLabel(r.robot_speed_mps, 0.1, 1)][r.outcome];
      ++by_feature["roadway_width_m"][bucketLabel(r.roadway_width_m, 0.5, 1)][r.outcome];
    }
    replans += r.replans;
    runs_with_replans += r.replans > 0;
    if (r.outcome == "error") return;
    path_length_mm += std::llround(r.path_length_m * 1000.0);
    if (std::isfinite(r.min_clearance_m)) min_clearance_m = std::min(min_clearance_m.value_or(r.min_clearance_m), r.min_clearance_m);
    ++step_p50[bucket(r.step_p50_us)];
    ++step_p99[bucket(r.step_p99_us)];
    if (r.outcome != "arrived") return;
    arrival_time_ms += std::llround(r.arrival_time_s * 1000.0);
    collisions_among_arrivals += r.collisions > 0;
    arrivals_beyond_tolerance += !(r.final_goal_distance_m <= r.arrival_tolerance_m);
  }
  void add(const Stats& o) {
    scenarios += o.scenarios;
    for (const auto& [k, v] : o.outcomes) outcomes[k] += v;
    collisions_among_arrivals += o.collisions_among_arrivals;
    arrivals_beyond_tolerance += o.arrivals_beyond_tolerance;
    replans += o.replans;
    runs_with_replans += o.runs_with_replans;
    arrival_time_ms += o.arrival_time_ms;
    path_length_mm += o.path_length_mm;
    if (o.min_clearance_m) min_clearance_m = std::min(min_clearance_m.value_or(*o.min_clearance_m), *o.min_clearance_m);
    for (const auto& [feature, buckets] : o.by_feature)
      for (const auto& [label, counts] : buckets)
        for (const auto& [outcome, n] : counts) by_feature[feature][label][outcome] += n;
    for (std::size_t k = 0; k < step_p50.size(); ++k) {
      step_p50[k] += o.step_p50[k];
      step_p99[k] += o.step_p99[k];
    }
  }
  // "counts" depends only on the campaign; "step_time_us" is measured (wall clock).
  Json countsJson() const {
    Json j;
    j["scenarios"] = scenarios;
    j["outcomes"] = Json(outcomes);
    j["collisions_among_arrivals"] = collisions_among_arrivals;
    j["arrivals_beyond_tolerance"] = arrivals_beyond_tolerance;
    j["replans"] = replans;
    j["runs_with_replans"] = runs_with_replans;
    j["arrival_time_ms_sum"] = arrival_time_ms;
    j["path_length_mm_sum"] = path_length_mm;
    j["min_clearance"] = min_clearance_m ? Json(*min_clearance_m) : Json(nullptr);
    j["outcomes_by_feature"] = Json(by_feature);
    return j;
  }
  Json stepJson() const {
    return {{"bucket_upper_edges", kStepEdgesUs}, {"p50_per_run", step_p50}, {"p99_per_run", step_p99}};
  }
  Json toJson() const { return {{"counts", countsJson()}, {"step_time_us", stepJson()}}; }
  static StatusOr<Stats> fromJson(const nlohmann::json& j, const std::string& file) {
    Stats s;
    try {
      const nlohmann::json& c = j.at("counts");
      s.scenarios = c.at("scenarios").get<long long>();
      for (const auto& [k, v] : c.at("outcomes").items()) s.outcomes[k] = v.get<long long>();
      s.collisions_among_arrivals = c.at("collisions_among_arrivals").get<long long>();
      s.arrivals_beyond_tolerance = c.at("arrivals_beyond_tolerance").get<long long>();
      s.replans = c.at("replans").get<long long>();
      s.runs_with_replans = c.at("runs_with_replans").get<long long>();
      s.arrival_time_ms = c.at("arrival_time_ms_sum").get<long long>();
      s.path_length_mm = c.at("path_length_mm_sum").get<long long>();
      if (!c.at("min_clearance").is_null()) s.min_clearance_m = c.at("min_clearance").get<double>();
      s.by_feature = c.at("outcomes_by_feature").get<decltype(s.by_feature)>();
      const nlohmann::json& t = j.at("step_time_us");
      if (t.at("bucket_upper_edges").get<std::vector<double>>() !=
          std::vector<double>(kStepEdgesUs.begin(), kStepEdgesUs.end()))
        return invalidArgument(file + ": stats.step_time_us: other bucket edges than this adit's");
      const auto p50 = t.at("p50_per_run").get<std::vector<long long>>(), p99 = t.at("p99_per_run").get<std::vector<long long>>();
      if (p50.size() != s.step_p50.size() || p99.size() != s.step_p99.size())
        return invalidArgument(file + ": stats.step_time_us: wrong number of buckets");
      std::copy(p50.begin(), p50.end(), s.step_p50.begin());
      std::copy(p99.begin(), p99.end(), s.step_p99.begin());
    } catch (const nlohmann::json::exception& e) {
      return invalidArgument(file + ": stats: " + e.what());
    }
    return s;
  }
};

std::string shardName(int k, int m, const char* ext) {
  return "shard-" + std::to_string(k) + "-of-" + std::to_string(m) + ext;
}

Status writeText(const std::string& path, const std::string& text) {
  return map::writeFileAtomically(path, [&](std::ostream& os) { return bool(os << text); });
}

Status parseShard(const std::string& text, int& k, int& m) {
  static const std::regex form(R"(([0-9]{1,9})/([0-9]{1,9}))");
  std::smatch g;
  if (!std::regex_match(text, g, form)) return invalidArgument("--shard must be K/M, e.g. 0/4 (got '" + text + "')");
  k = std::stoi(g[1]);
  m = std::stoi(g[2]);
  if (m < 1 || k >= m) return invalidArgument("--shard K/M needs 0 <= K < M (got " + text + ")");
  return Status();
}

int runShard(const CampaignArgs& a) {
  int k = 0, m = 1;
  if (Status s = parseShard(a.shard, k, m); !s.ok()) return report(s);
  if (a.scenarios < 1) return report(invalidArgument("--scenarios must be >= 1 (got " + std::to_string(a.scenarios) + ")"));
  if (m > a.scenarios)
    return report(invalidArgument("--shard " + a.shard + ": more shards than scenarios (" + std::to_string(a.scenarios) + ")"));
  if (a.jobs < 1) return report(invalidArgument("--jobs must be >= 1 (got " + std::to_string(a.jobs) + ")"));
  if (a.out.empty()) return report(invalidArgument("--out DIR is required"));
  fusion::BatchParams bp;
  if (!a.generator.empty()) {
    StatusOr<std::string> text = map::readFile(a.generator);
    if (!text.ok()) return report(text.status());
    StatusOr<fusion::BatchParams> p = fusion::parseBatchParams(*text, a.generator);
    if (!p.ok()) return report(p.status());
    bp = *p;
  }
  bp.seed = a.seed;
  // Given means checked: NaN or a negative value is refused (by validate()), never taken for
  // "not given".
  if (a.t_max_given) bp.t_max_s = a.t_max;
  if (a.max_separation_given) bp.max_separation_m = a.max_separation;
  if (Status s = bp.validate(); !s.ok()) return report(s);
  const auto wall0 = std::chrono::steady_clock::now();
  CampaignIdentity id;
  id.map = a.map;
  id.seed = a.seed;
  id.scenarios = a.scenarios;
  id.shards = m;
  id.generator = bp;
  id.adit_version = ADIT_VERSION;
  id.adit_commit = ADIT_COMMIT;
  if (a.map.empty()) return report(invalidArgument("--map is required (a survey .yaml)"));
  StatusOr<std::string> hash = fileContentHash(a.map);
  if (!hash.ok()) return report(hash.status());
  id.map_hash = *hash;
  StatusOr<BatchSetup> setup = loadBatchSetup("", a.map);
  if (!setup.ok()) return report(setup.status());
  // Bad generator ranges show in the first scenario: refuse them before forking.
  if (StatusOr<local::Scenario> first = fusion::makeBatchScenario(setup->base, setup->survey, setup->truth, bp, k);
      !first.ok())
    return report(first.status());
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (!std::filesystem::is_directory(a.out))
    return report(invalidArgument(a.out + ": --out: cannot create the directory" + (ec ? ": " + ec.message() : "")));
  // The shard's files are written at its end: an unwritable directory is said now, not after the run.
  if (Status s = checkOutputPath(a.out + "/" + shardName(k, m, ".json"), "--out"); !s.ok()) return report(s);
  std::vector<int> indices;
  for (int i = k; i < a.scenarios; i += m) indices.push_back(i);
  if (!a.quiet)
    std::fprintf(stderr, "adit: campaign shard %d of %d: %zu of %d scenarios on %s (seed %llu, %d workers)\n", k, m,
                 indices.size(), a.scenarios, a.map.c_str(), static_cast<unsigned long long>(a.seed),
                 std::min<int>(a.jobs, int(indices.size())));
  ProgressBar bar(a.quiet);
  StatusOr<std::vector<fusion::BatchRunResult>> runs = runBatchWorkers(*setup, bp, indices, a.jobs, bar, "shard");
  if (!runs.ok()) return report(runs.status());
  Stats stats;
  Json failures = Json::array();
  std::string csv = std::string(fusion::batchCsvHeader()) + "\n";
  for (const fusion::BatchRunResult& r : *runs) {
    stats.add(r);
    csv += fusion::batchCsvRow(r) + "\n";
    if (r.outcome != "arrived" || r.collisions > 0)
      failures.push_back({{"index", r.index}, {"seed", r.seed}, {"outcome", r.outcome}, {"collisions", r.collisions},
                          {"message", r.message}});
  }
  const std::string base = (std::filesystem::path(a.out) / shardName(k, m, "")).string();
  if (Status s = writeText(base + ".csv", csv); !s.ok()) return report(s);
  Json j;
  j["campaign"] = campaignIdentityJson(id);
  j["shard"] = {{"index", k}, {"count", m}, {"indices", "i mod " + std::to_string(m) + " == " + std::to_string(k)},
                {"csv", shardName(k, m, ".csv")}};
  j["stats"] = stats.toJson();
  j["failures"] = failures;
  j["jobs"] = std::min<int>(a.jobs, int(indices.size()));
  j["wall_time"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  if (Status s = writeText(base + ".json", j.dump(2) + "\n"); !s.ok()) return report(s);
  if (!a.quiet)
    std::fprintf(stderr, "adit: shard %d of %d: %lld arrived of %lld, %lld errors, %lld collisions among arrivals, %.1f s -> %s.json\n",
                 k, m, stats.outcomes["arrived"], stats.scenarios, stats.outcomes["error"], stats.collisions_among_arrivals,
                 j["wall_time"].get<double>(), base.c_str());
  const bool ok = stats.outcomes["error"] == 0 && stats.collisions_among_arrivals == 0 && stats.arrivals_beyond_tolerance == 0;
  return ok ? kExitOk : kExitFailure;
}

struct ShardFile {
  std::string path, dir;
  nlohmann::json json;
  CampaignIdentity id;
  int k = 0;
};

// The identity fields that make two shards parts of one campaign (the map path may differ
// between machines; its content may not).
std::vector<std::string> identityDifferences(const CampaignIdentity& a, const CampaignIdentity& b) {
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

// The merged report as one offline page: outcome counts, success rate per feature bucket as
// bars (HTML/CSS, no picture), and the failures with their replay commands.
std::string reportPage(const Json& j) {
  auto bar = [](double fraction, const char* colour) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "<div class=bar><div style=\"width:%.1f%%;background:%s\"></div></div>",
                  100.0 * fraction, colour);
    return std::string(buf);
  };
  auto percent = [](double f) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f %%", 100.0 * f);
    return std::string(buf);
  };
  const Json& c = j["campaign"];
  const Json& counts = j["stats"]["counts"];
  const double n = counts["scenarios"].get<double>();
  std::string h =
      "<!doctype html>\n<html lang=en><head><meta charset=utf-8><title>adit campaign report</title><style>"
      "body{font:14px sans-serif;margin:2em;max-width:70em}table{border-collapse:collapse;margin-bottom:1.5em}"
      "td,th{padding:2px 10px;text-align:left;border-bottom:1px solid #ddd}.bar{width:20em;height:12px;"
      "background:#eee}.bar div{height:12px}code{font-size:12px}</style></head><body>\n";
  h += "<h1>Campaign report</h1>\n<p>" + htmlEscape(c["map"].get<std::string>()) + " (" +
       htmlEscape(c["map_hash"].get<std::string>()) + "), seed " + std::to_string(c["seed"].get<std::uint64_t>()) + ", " +
       std::to_string(c["scenarios"].get<int>()) + " scenarios in " + std::to_string(c["shards"].get<int>()) +
       " shards, adit " + htmlEscape(c["adit_version"].get<std::string>()) + ". Success rate <b>" +
       percent(j["success_rate"].get<double>()) + "</b>; collisions among arrivals <b>" +
       std::to_string(counts["collisions_among_arrivals"].get<long long>()) + "</b>; arrivals beyond tolerance <b>" +
       std::to_string(counts["arrivals_beyond_tolerance"].get<long long>()) + "</b>.</p>\n";
  h += "<h2>Outcomes</h2>\n<table><tr><th>outcome</th><th>scenarios</th><th>share</th><th></th></tr>\n";
  for (const auto& [outcome, count] : counts["outcomes"].items()) {
    const double f = count.get<double>() / n;
    h += "<tr><td>" + htmlEscape(outcome) + "</td><td>" + std::to_string(count.get<long long>()) + "</td><td>" +
         percent(f) + "</td><td>" + bar(f, outcome == "arrived" ? "#2a9d8f" : "#e76f51") + "</td></tr>\n";
  }
  h += "</table>\n<h2>Success rate by scenario feature</h2>\n";
  for (const auto& [feature, buckets] : j["success_rate_by_feature"].items()) {
    h += "<h3>" + htmlEscape(feature) + "</h3>\n<table><tr><th>bucket</th><th>scenarios</th><th>success rate</th><th></th></tr>\n";
    for (const auto& [label, b] : buckets.items()) {
      const double f = b["success_rate"].get<double>();
      h += "<tr><td>" + htmlEscape(label) + "</td><td>" + std::to_string(b["scenarios"].get<long long>()) + "</td><td>" +
           percent(f) + "</td><td>" + bar(f, "#2a9d8f") + "</td></tr>\n";
    }
    h += "</table>\n";
  }
  // A page stays readable: the JSON lists every failure, the page the first 1000.
  const Json& failures = j["failures"];
  h += "<h2>Failures (" + std::to_string(failures.size()) + ")</h2>\n";
  if (failures.size() > 1000) h += "<p>The first 1000; the JSON report lists them all.</p>\n";
  h += "<table><tr><th>index</th><th>outcome</th><th>message</th><th>replay</th></tr>\n";
  for (std::size_t k = 0; k < failures.size() && k < 1000; ++k) {
    const Json& f = failures[k];
    h += "<tr><td>" + std::to_string(f["index"].get<long long>()) + "</td><td>" +
         htmlEscape(f["outcome"].get<std::string>()) + "</td><td>" + htmlEscape(f.value("message", std::string())) +
         "</td><td><code>" + htmlEscape(f["replay"].get<std::string>()) + "</code></td></tr>\n";
  }
  return h + "</table>\n</body></html>\n";
}

int merge(const CampaignArgs& a) {
  if (!a.html.empty() && (a.html.size() < 5 || a.html.substr(a.html.size() - 5) != ".html"))
    return report(invalidArgument(a.html + ": --html must end in .html"));
  static const std::regex name(R"(shard-([0-9]+)-of-([0-9]+)\.json)");
  std::vector<std::string> files, problems;
  for (const std::string& in : a.inputs) {
    std::error_code ec;
    if (std::filesystem::is_directory(in, ec)) {
      std::vector<std::string> found;
      for (const auto& e : std::filesystem::directory_iterator(in, ec))
        if (std::regex_match(e.path().filename().string(), name)) found.push_back(e.path().string());
      if (found.empty()) problems.push_back(in + ": no shard-K-of-M.json in this directory");
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  std::vector<ShardFile> shards;
  for (const std::string& f : files) {
    StatusOr<std::string> text = map::readFile(f);
    if (!text.ok()) {
      problems.push_back(text.status().message());
      continue;
    }
    ShardFile s;
    s.path = f;
    s.dir = std::filesystem::path(f).parent_path().string();
    if (s.dir.empty()) s.dir = ".";
    s.json = nlohmann::json::parse(*text, nullptr, false);
    if (s.json.is_discarded()) {
      problems.push_back(f + ": not JSON");
      continue;
    }
    StatusOr<CampaignIdentity> id = campaignIdentityFromJson(s.json, f);
    if (!id.ok()) {
      problems.push_back(id.status().message());
      continue;
    }
    s.id = *id;
    if (!s.json.contains("shard") || !s.json["shard"].contains("index") || !s.json["shard"]["index"].is_number_integer()) {
      problems.push_back(f + ": no shard.index");
      continue;
    }
    s.k = s.json["shard"]["index"].get<int>();
    if (s.k < 0 || s.k >= s.id.shards) {
      problems.push_back(f + ": shard.index " + std::to_string(s.k) + " outside 0.." + std::to_string(s.id.shards - 1));
      continue;
    }
    shards.push_back(std::move(s));
  }
  if (shards.empty() && problems.empty()) problems.push_back("no shard given");
  std::map<int, const ShardFile*> by_k;
  for (const ShardFile& s : shards) {
    const std::vector<std::string> d = identityDifferences(shards.front().id, s.id);
    if (!d.empty()) {
      std::string why;
      for (const std::string& x : d) why += (why.empty() ? "" : ", ") + x;
      problems.push_back(s.path + ": a shard of another campaign than " + shards.front().path + ": " + why);
      continue;
    }
    if (auto [it, fresh] = by_k.emplace(s.k, &s); !fresh)
      problems.push_back(s.path + ": duplicate of shard " + std::to_string(s.k) + " (also " + it->second->path + ")");
  }
  if (!shards.empty() && problems.empty()) {
    const CampaignIdentity& id = shards.front().id;
    std::string missing;
    for (int k = 0; k < id.shards; ++k)
      if (!by_k.count(k)) missing += (missing.empty() ? "" : ", ") + shardName(k, id.shards, ".json");
    if (!missing.empty()) problems.push_back("missing shards of the campaign of " + shards.front().path + ": " + missing);
  }
  // Statistics and rows (the rows when --csv is asked for).
  Stats total;
  std::vector<std::pair<int, Json>> failures;
  std::vector<std::pair<int, std::string>> rows;
  for (const auto& [k, s] : by_k) {
    if (!problems.empty()) break;
    StatusOr<Stats> st = Stats::fromJson(s->json.value("stats", nlohmann::json::object()), s->path);
    if (!st.ok()) {
      problems.push_back(st.status().message());
      continue;
    }
    const long long expected = (s->id.scenarios - k + s->id.shards - 1) / s->id.shards;
    if (st->scenarios != expected) {
      problems.push_back(s->path + ": " + std::to_string(st->scenarios) + " scenarios, shard " + std::to_string(k) +
                         " of " + std::to_string(s->id.shards) + " has " + std::to_string(expected));
      continue;
    }
    total.add(*st);
    for (const auto& f : s->json.value("failures", nlohmann::json::array())) {
      Json e = f;
      const std::string i = std::to_string(f.value("index", -1));
      e["replay"] = "adit simulate --replay " + s->dir + ":" + i + " --picture replay-" + i + ".png --html replay-" + i + ".html";
      failures.emplace_back(f.value("index", -1), e);
    }
    if (!a.csv.empty()) {
      const std::string csv_path = (std::filesystem::path(s->dir) / shardName(k, s->id.shards, ".csv")).string();
      StatusOr<std::string> text = map::readFile(csv_path);
      if (!text.ok()) {
        problems.push_back(text.status().message());
        continue;
      }
      std::istringstream is(*text);
      std::string line;
      std::getline(is, line);  // header
      long long n = 0;
      for (; std::getline(is, line); ++n) rows.emplace_back(std::atoi(line.c_str()), line);
      if (n != expected) problems.push_back(csv_path + ": " + std::to_string(n) + " rows, expected " + std::to_string(expected));
    }
  }
  if (!problems.empty()) {
    for (const std::string& p : problems) std::fprintf(stderr, "adit: error: %s\n", p.c_str());
    std::fprintf(stderr, "adit: error: refusing to merge (%zu problem%s)\n", problems.size(), problems.size() == 1 ? "" : "s");
    return kExitBadInput;
  }
  const CampaignIdentity& id = shards.front().id;
  std::sort(failures.begin(), failures.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  Json failure_list = Json::array();
  for (auto& f : failures) failure_list.push_back(std::move(f.second));
  CampaignIdentity whole = id;
  Json j;
  j["campaign"] = campaignIdentityJson(whole);
  Json inputs = Json::array();
  for (const auto& [k, s] : by_k) inputs.push_back(s->path);
  j["shard_files"] = inputs;
  j["stats"] = total.toJson();
  const double n = double(total.scenarios);
  const long long arrived = total.outcomes["arrived"];
  j["success_rate"] = arrived / n;
  j["mean_arrival_time"] = arrived > 0 ? Json(total.arrival_time_ms / 1000.0 / double(arrived)) : Json(nullptr);
  // The rates behind the issue's plots of outcome against scenario features (the plots: not done).
  Json by_feature;
  for (const auto& [feature, buckets] : total.by_feature)
    for (const auto& [label, counts] : buckets) {
      long long runs = 0;
      for (const auto& c : counts) runs += c.second;
      const auto it = counts.find("arrived");
      const long long ok = it == counts.end() ? 0 : it->second;
      by_feature[feature][label] = {{"scenarios", runs}, {"success_rate", double(ok) / double(runs)}};
    }
  j["success_rate_by_feature"] = by_feature;
  j["failures"] = failure_list;
  if (!a.csv.empty()) {
    std::sort(rows.begin(), rows.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    std::string csv = std::string(fusion::batchCsvHeader()) + "\n";
    for (const auto& r : rows) csv += r.second + "\n";
    if (Status s = writeText(a.csv, csv); !s.ok()) return report(s);
  }
  if (!a.html.empty())
    if (Status s = writeText(a.html, reportPage(j)); !s.ok()) return report(s);
  const std::string text = j.dump(2) + "\n";
  if (!a.report.empty()) {
    if (Status s = writeText(a.report, text); !s.ok()) return report(s);
  } else {
    std::fwrite(text.data(), 1, text.size(), stdout);
  }
  if (!a.quiet)
    std::fprintf(stderr,
                 "adit: merged %d shards, %lld scenarios: success rate %.3f, %lld errors, %lld collisions among "
                 "arrivals, %zu failures listed\n",
                 id.shards, total.scenarios, arrived / n, total.outcomes["error"], total.collisions_among_arrivals,
                 failure_list.size());
  const bool ok = total.outcomes["error"] == 0 && total.collisions_among_arrivals == 0 && total.arrivals_beyond_tolerance == 0;
  return ok ? kExitOk : kExitFailure;
}

}  // namespace

void registerCampaignVerb(CLI::App& app, int* rc) {
  auto args = std::make_shared<CampaignArgs>();
  CLI::App* cmd = app.add_subcommand("campaign", "Validation campaigns: randomized scenario batches in shards, merged exactly");
  cmd->require_subcommand(1);
  CLI::App* run = cmd->add_subcommand(
      "run",
      "Run shard K of M of a campaign of N scenarios (indices i with i mod M == K): writes "
      "DIR/shard-K-of-M.csv and .json atomically; exit 1 if a scenario errored or an arrival collided");
  run->add_option("--map", args->map, "The survey map (.yaml)")->required();
  run->add_option("--scenarios", args->scenarios, "N: scenario indices 0..N-1")->required();
  run->add_option("--seed", args->seed, "Campaign seed (each scenario's seed derives from it and its index)");
  run->add_option("--shard", args->shard, "K/M: this shard (default 0/1: the whole campaign)");
  run->add_option("--jobs", args->jobs, "Worker processes (the rows do not depend on it)");
  run->add_option("--out", args->out, "Campaign directory (created if missing)")->required();
  run->add_option("--generator", args->generator, "Scenario generator ranges (YAML; see README)");
  run->add_option("--t-max", args->t_max, "Simulated-time cap per scenario [s] (overrides the generator's t_max)");
  run->add_option("--max-separation", args->max_separation,
                  "Largest start-goal distance [m] (overrides the generator's separation maximum)");
  run->add_flag("-q,--quiet", args->quiet, "No log on stderr");
  run->callback([args, rc, run] {
    args->t_max_given = run->count("--t-max") > 0;
    args->max_separation_given = run->count("--max-separation") > 0;
    *rc = runShard(*args);
  });
  CLI::App* mg = cmd->add_subcommand(
      "merge",
      "Merge every shard of a campaign into one report (JSON on stdout or --out); exit 2 on missing, "
      "duplicate or foreign shards, 1 if a scenario errored or an arrival collided");
  mg->add_option("INPUTS", args->inputs, "Campaign directories or shard JSON files")->required();
  mg->add_option("--out", args->report, "Write the report here (atomically) instead of stdout");
  mg->add_option("--csv", args->csv, "Also write every shard's rows, sorted by index, into this CSV");
  mg->add_option("--html", args->html,
                 "Also write the report as a page (.html, offline): outcomes, success rate by scenario feature, "
                 "failures with their replay commands");
  mg->add_flag("-q,--quiet", args->quiet, "No log on stderr");
  mg->callback([args, rc] { *rc = merge(*args); });
}

}  // namespace adit::tools
