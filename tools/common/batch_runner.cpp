// SPDX-License-Identifier: BSD-3-Clause
#include "common/batch_runner.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <new>
#include <optional>
#include <regex>

#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "adit/map/map_io.hpp"
#include "adit/map/content_hash.hpp"
#include "common/plan_output.hpp"

namespace adit::tools {

namespace {

// One run's record as a worker writes it for the parent: tab-separated, full precision.
std::string batchRecord(const sim::BatchRunResult& r) {
  std::string msg = r.message;
  std::replace_if(msg.begin(), msg.end(), [](char c) { return c == '\t' || c == '\n' || c == '\r'; }, ' ');
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%d\t%llu\t%s\t%.17g\t%.17g\t%.17g\t%d\t%d\t%.17g\t%.17g\t%.17g\t%.17g\t%d\t%d\t%.17g\t%.17g\t%.17g\t%.17g\t%s\t",
                r.index, static_cast<unsigned long long>(r.seed), r.outcome.c_str(), r.arrival_time_s, r.path_length_m,
                r.min_clearance_m, r.collisions, r.replans, r.step_p50_us, r.step_p99_us, r.final_goal_distance_m,
                r.arrival_tolerance_m, r.vehicles, int(r.roof_fall), r.separation_m, r.robot_radius_m, r.robot_speed_mps,
                r.roadway_width_m, sim::endCauseName(r.end_cause));
  return buf + msg + "\n";
}

std::optional<sim::BatchRunResult> parseBatchRecord(const std::string& line) {
  std::vector<std::string> f;
  std::size_t from = 0;
  for (int k = 0; k < 19; ++k) {
    const std::size_t tab = line.find('\t', from);
    if (tab == std::string::npos) return std::nullopt;
    f.push_back(line.substr(from, tab - from));
    from = tab + 1;
  }
  sim::BatchRunResult r;
  auto num = [](const std::string& s) { return std::strtod(s.c_str(), nullptr); };
  r.index = std::atoi(f[0].c_str());
  r.seed = std::strtoull(f[1].c_str(), nullptr, 10);
  r.outcome = f[2];
  r.arrival_time_s = num(f[3]);
  r.path_length_m = num(f[4]);
  r.min_clearance_m = num(f[5]);
  r.collisions = std::atoi(f[6].c_str());
  r.replans = std::atoi(f[7].c_str());
  r.step_p50_us = num(f[8]);
  r.step_p99_us = num(f[9]);
  r.final_goal_distance_m = num(f[10]);
  r.arrival_tolerance_m = num(f[11]);
  r.vehicles = std::atoi(f[12].c_str());
  r.roof_fall = f[13] == "1";
  r.separation_m = num(f[14]);
  r.robot_radius_m = num(f[15]);
  r.robot_speed_mps = num(f[16]);
  r.roadway_width_m = num(f[17]);
  const std::optional<sim::EndCause> cause = sim::endCauseFromName(f[18]);
  if (!cause) return std::nullopt;
  r.end_cause = *cause;
  r.message = line.substr(from);
  return r;
}

// Runs scenario `index`, drawn beforehand (`sc`: the scenario or why it could not be drawn).
sim::BatchRunResult runOne(const BatchSetup& setup, const sim::BatchParams& params, int index,
                           const StatusOr<sim::Scenario>& sc) {
  if (sc.ok()) {
    sim::BatchRunResult r = sim::runBatchScenario(*sc, setup.truth, index, &setup.believed);
    r.roadway_width_m = setup.roadways.widthAt(sc->start);
    return r;
  }
  sim::BatchRunResult r;
  r.index = index;
  r.seed = sim::batchRunSeed(params.seed, index);
  r.outcome = "error";
  r.message = sc.status().message();
  return r;
}

}  // namespace

StatusOr<BatchSetup> loadBatchSetup(const std::string& scenario_file, const std::string& map, bool no_cache) {
  StatusOr<sim::Scenario> sc = internalError("no base");
  if (!scenario_file.empty()) {
    sc = sim::loadScenario(scenario_file);
  } else {
    if (map.empty()) return invalidArgument("--batch needs --map (or a scenario file)");
    sc = sim::parseScenario("map: " + nlohmann::json(map).dump() +
                                  "\nstart: [0, 0, 0]\ngoal: [1, 0, 0]\nexpected_path: plan\n"
                                  "robot: {radius: 0.4, v_max: 1.0, a_max: 0.5, sensor_range: 8}\n"
                                  "method: tian2016\nparams: {rho0_m: 1.0}\ndt: 0.1\n",
                              "batch");
  }
  if (!sc.ok()) return sc.status();
  if (!scenario_file.empty() && !map.empty()) sc->map_path = map;
  if (!sc->map_path) return invalidArgument(sc->file + ": map: --batch needs a map");
  const std::string& map_path = *sc->map_path;
  map::WorldOptions options;
  options.cache = verbCacheOptions(no_cache);
  ADIT_ASSIGN_OR_RETURN(map::World believed, map::World::load(map_path, options));
  sim::BatchRoadways roadways;
  if (believed.survey()) {
    roadways = sim::BatchRoadways::fromSurvey(*believed.survey());
  } else {
    // The passages the base robot fits through with room to spare (the generator's own test
    // for a start or goal: clearance above radius + 0.4 m).
    StatusOr<sim::BatchRoadways> r =
        sim::BatchRoadways::fromFreeSpace(believed.map(), believed.field(), sc->params.robot.radius_m + 0.4);
    if (!r.ok()) return invalidArgument(map_path + ": no roadways to draw starts and goals on: " + r.status().message());
    roadways = std::move(r).value();
  }
  // Read the voxels' states now, so that the workers forked later share them instead of each
  // building them (or a cached map's octree) on its first scan.
  believed.map().prepareVoxelQueries();
  ADIT_ASSIGN_OR_RETURN(sim::Environment truth, sim::Environment::borrow(believed));
  return BatchSetup{std::move(sc).value(), std::move(roadways), std::move(believed), std::move(truth)};
}

StatusOr<std::vector<sim::BatchRunResult>> runBatchWorkers(const BatchSetup& setup,
                                                                const sim::BatchParams& params,
                                                                const std::vector<int>& indices, int jobs_wanted,
                                                                ProgressBar& bar, const char* stage) {
  const int total = int(indices.size());
  if (total == 0) return std::vector<sim::BatchRunResult>{};
  const int jobs = std::max(1, std::min(jobs_wanted, total));
  // One unlinked temporary file per worker (tmpfile()): a killed batch leaves nothing behind.
  std::vector<std::FILE*> files;
  auto closeAll = [&files] {
    for (std::FILE* f : files) std::fclose(f);
  };
  for (int w = 0; w < jobs; ++w) {
    std::FILE* f = std::tmpfile();
    if (!f) {
      closeAll();
      return internalError(std::string("cannot create a temporary file: ") + std::strerror(errno));
    }
    files.push_back(f);
  }
  // The scenarios are drawn here, once (about 0.1 ms each), and the workers inherit them. Longest
  // first: a worker that draws a long run last keeps the other idle at the end (on 60 district
  // scenarios the runs take 0.1-4 s). A run's length goes with its start-goal distance and
  // doubles with a roof fall (the detour). Records are written and read by index, so the order
  // changes no row.
  std::vector<StatusOr<sim::Scenario>> drawn;
  drawn.reserve(indices.size());
  std::vector<std::pair<double, int>> by_cost;
  by_cost.reserve(indices.size());
  for (int k = 0; k < total; ++k) {
    drawn.push_back(sim::makeBatchScenario(setup.base, setup.roadways, setup.truth, params, indices[std::size_t(k)]));
    const StatusOr<sim::Scenario>& sc = drawn.back();
    const double cost = sc.ok() ? (sc->goal - sc->start).norm() * (sc->events.empty() ? 1.0 : 2.0) : 0.0;
    by_cost.emplace_back(-cost, k);
  }
  std::stable_sort(by_cost.begin(), by_cost.end());
  std::vector<int> order;
  order.reserve(by_cost.size());
  for (const auto& c : by_cost) order.push_back(c.second);
  // Workers pull positions in `order` from a counter in shared memory, write one record per
  // run to their own file and one byte per run to the progress pipe. A worker dies with its
  // parent (PR_SET_PDEATHSIG): a killed shard leaves no worker computing rows nobody reads.
  auto* next = static_cast<std::atomic<int>*>(
      ::mmap(nullptr, sizeof(std::atomic<int>), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  if (next == MAP_FAILED) {
    closeAll();
    return internalError(std::string("mmap: ") + std::strerror(errno));
  }
  new (next) std::atomic<int>(0);
  int progress[2];
  if (::pipe(progress) != 0) {
    closeAll();
    return internalError(std::string("pipe: ") + std::strerror(errno));
  }
  bar.update(stage, 0.0);  // the stage's clock starts now, not at the first finished run
  std::fflush(nullptr);
  std::vector<pid_t> pids;
  const pid_t parent = ::getpid();
  for (int w = 0; w < jobs; ++w) {
    const pid_t pid = ::fork();
    if (pid < 0) {
      // Workers already started finish their runs unread.
      closeAll();
      return internalError(std::string("fork: ") + std::strerror(errno));
    }
    if (pid == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != parent) ::_exit(1);  // the parent died before prctl
      ::close(progress[0]);
      std::FILE* out = files[std::size_t(w)];
      for (int k = next->fetch_add(1); k < total; k = next->fetch_add(1)) {
        const std::size_t at = std::size_t(order[std::size_t(k)]);
        const std::string rec = batchRecord(runOne(setup, params, indices[at], drawn[at]));
        std::fwrite(rec.data(), 1, rec.size(), out);
        std::fflush(out);
        const char one = '.';
        if (::write(progress[1], &one, 1) != 1) break;
      }
      ::_exit(std::fclose(out) == 0 ? 0 : 1);
    }
    pids.push_back(pid);
  }
  ::close(progress[1]);
  int done = 0;
  char buf[256];
  for (ssize_t n; (n = ::read(progress[0], buf, sizeof buf)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    done += int(n);
    bar.update(stage, double(done) / total);
  }
  ::close(progress[0]);
  bar.finish();
  bool workers_ok = true;
  for (pid_t pid : pids) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    workers_ok = workers_ok && WIFEXITED(status) && WEXITSTATUS(status) == 0;
  }
  ::munmap(next, sizeof(std::atomic<int>));
  std::vector<std::optional<sim::BatchRunResult>> by_index;
  by_index.resize(std::size_t(total));
  std::vector<std::pair<int, std::size_t>> position;  // index -> position in `indices`
  for (std::size_t k = 0; k < indices.size(); ++k) position.emplace_back(indices[k], k);
  std::sort(position.begin(), position.end());
  for (int w = 0; w < jobs; ++w) {
    std::FILE* in = files[std::size_t(w)];
    std::rewind(in);  // the worker wrote through the same open file; it has exited
    std::string line;
    for (int c; (c = std::fgetc(in)) != EOF;) {
      if (c != '\n') {
        line.push_back(char(c));
        continue;
      }
      std::optional<sim::BatchRunResult> r = parseBatchRecord(line);
      line.clear();
      if (!r) continue;
      const auto it = std::lower_bound(position.begin(), position.end(), std::make_pair(r->index, std::size_t(0)));
      if (it != position.end() && it->first == r->index) by_index[it->second] = std::move(r);
    }
  }
  closeAll();
  std::vector<sim::BatchRunResult> runs;
  for (std::size_t k = 0; k < by_index.size(); ++k) {
    if (!by_index[k]) return internalError("batch: run " + std::to_string(indices[k]) + " was lost (a worker " +
                                           (workers_ok ? "wrote no record" : "failed") + ")");
    runs.push_back(std::move(*by_index[k]));
  }
  return runs;
}

StatusOr<sim::Scenario> replayScenario(const std::string& spec, const std::string& map_override) {
  const std::size_t colon = spec.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == spec.size())
    return invalidArgument("--replay " + spec + ": expected CAMPAIGN:INDEX (a campaign directory or shard JSON)");
  const std::string campaign = spec.substr(0, colon), index_text = spec.substr(colon + 1);
  char* end = nullptr;
  errno = 0;
  const long index = std::strtol(index_text.c_str(), &end, 10);
  if (errno != 0 || *end != '\0' || index < 0 || index > 2147483647L)
    return invalidArgument("--replay " + spec + ": INDEX must be an integer >= 0 (got '" + index_text + "')");
  std::string shard = campaign;
  std::error_code ec;
  if (std::filesystem::is_directory(campaign, ec)) {
    shard.clear();
    static const std::regex name(R"(shard-[0-9]+-of-[0-9]+\.json)");
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(campaign, ec))
      if (std::regex_match(e.path().filename().string(), name)) found.push_back(e.path().string());
    if (found.empty()) return invalidArgument(campaign + ": no shard-K-of-M.json in this campaign directory");
    std::sort(found.begin(), found.end());
    shard = found.front();
  }
  ADIT_ASSIGN_OR_RETURN(const std::string text, map::readFile(shard));
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return invalidArgument(shard + ": not JSON");
  ADIT_ASSIGN_OR_RETURN(const sim::CampaignIdentity id, sim::campaignIdentityFromJson(j, shard));
  if (index >= id.scenarios)
    return invalidArgument("--replay " + spec + ": the campaign has scenarios 0.." + std::to_string(id.scenarios - 1));
  // The identity keeps the map as `campaign run` was given it (shards on other machines agree on
  // a relative path where absolute ones differ), so a relative one means: from where that ran.
  const std::string& map_path = map_override.empty() ? id.map : map_override;
  if (map_override.empty() && !std::filesystem::path(id.map).is_absolute() && !std::filesystem::exists(id.map, ec))
    return invalidArgument(id.map + ": the campaign's map (recorded in " + shard +
                           " relative to where `adit campaign run` ran) is not found from " +
                           std::filesystem::current_path(ec).string() +
                           ": replay from that directory, or give the map with --map FILE (its content must not have changed)");
  ADIT_ASSIGN_OR_RETURN(const std::string hash, map::fileContentHash(map_path));
  if (hash != id.map_hash)
    return invalidArgument(map_path + ": the map changed since the campaign (" + hash + ", recorded " + id.map_hash +
                           " in " + shard + ")");
  ADIT_ASSIGN_OR_RETURN(const BatchSetup setup, loadBatchSetup("", map_path));
  return sim::makeBatchScenario(setup.base, setup.roadways, setup.truth, id.generator, int(index));
}

}  // namespace adit::tools
