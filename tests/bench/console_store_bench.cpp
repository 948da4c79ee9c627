// SPDX-License-Identifier: BSD-3-Clause
// The console store's write and replay rates (issue 11): telemetry appendMessage() rows per
// second, one transaction per message as the server stores them, then in batches of N in one
// transaction (appendMessages), and a 1,000-message history replay; on SQLite (a file in
// $TMPDIR) and on PostgreSQL when a server is named:
//
//   tests/console/postgres_fixture.sh start /tmp/pgbench    # a throw-away server
//   ADIT_BENCH_POSTGRES_URL=$(cat /tmp/pgbench/url) build/tests/adit_console_store_bench
//   tests/console/postgres_fixture.sh stop /tmp/pgbench
//
// Wall-clock time (UseRealTime): the cost is the disk flush at each commit, not CPU. The
// summary prints each backend's batch speed-up against its own one-per-transaction baseline,
// and SQLite against PostgreSQL, all measured in this run.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

#include "adit/console/store.hpp"

namespace {

using adit::console::RobotMessage;
using adit::console::Store;
namespace fs = std::filesystem;

/// The store of a backend, opened once per process; nullptr (with a reason) when unavailable.
Store* storeFor(const std::string& backend, std::string& why) {
  static std::map<std::string, std::unique_ptr<Store>> stores;
  auto it = stores.find(backend);
  if (it != stores.end()) return it->second.get();
  std::string url;
  if (backend == "sqlite") {
    const fs::path file = fs::temp_directory_path() / ("adit-store-bench-" + std::to_string(getpid()) + ".db");
    url = "sqlite:" + file.string();
    std::atexit([] {
      const std::string base = (fs::temp_directory_path() / ("adit-store-bench-" + std::to_string(getpid()) + ".db")).string();
      for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(base + suffix);
    });
  } else {
    const char* env = std::getenv("ADIT_BENCH_POSTGRES_URL");
    if (!env) {
      why = "ADIT_BENCH_POSTGRES_URL unset (start a throw-away server with tests/console/postgres_fixture.sh)";
      return nullptr;
    }
    url = env;
  }
  adit::StatusOr<std::unique_ptr<Store>> s = Store::open(url);
  if (!s.ok()) {
    why = s.status().toString();
    return nullptr;
  }
  return (stores[backend] = std::move(*s)).get();
}

/// A fresh robot id per benchmark run, so every run's seqs start at 1 and none is a duplicate.
std::string freshRobot() {
  static int n = 0;
  return "bench-" + std::to_string(getpid()) + "-" + std::to_string(++n);
}

RobotMessage telemetry(const std::string& robot, std::int64_t seq) {
  RobotMessage m;
  m.robot = robot;
  m.seq = seq;
  m.type = "telemetry";
  m.t = 0.02 * static_cast<double>(seq);
  m.received_at = "2026-11-30T23:00:00.000Z";
  // A realistic body: the protocol's telemetry message, ~230 bytes.
  m.body = R"({"type":"telemetry","robot":")" + robot + R"(","seq":)" + std::to_string(seq) +
           R"(,"t":12.3,"pose":[104.25,-33.5,-2.75],"velocity":[0.6,0.05,0.0],"status":"following",)"
           R"("goal":[210.0,-40.0,-3.0],"subgoal":[106.0,-33.4,-2.75],"min_clearance":0.81})";
  m.pose = RobotMessage::Pose{104.25, -33.5, -2.75, 0.6, 0.05, 0.0, "following"};
  return m;
}

void BM_AppendOnePerTransaction(benchmark::State& state, const std::string& backend) {
  std::string why;
  Store* db = storeFor(backend, why);
  if (!db) return state.SkipWithError(why.c_str());
  const std::string robot = freshRobot();
  std::int64_t seq = 0;
  for (auto _ : state) {
    adit::StatusOr<bool> r = db->appendMessage(telemetry(robot, ++seq));
    if (!r.ok() || !*r) return state.SkipWithError("append failed");
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_AppendBatch(benchmark::State& state, const std::string& backend) {
  std::string why;
  Store* db = storeFor(backend, why);
  if (!db) return state.SkipWithError(why.c_str());
  const std::string robot = freshRobot();
  const auto batch_size = static_cast<std::size_t>(state.range(0));
  std::vector<RobotMessage> batch(batch_size);
  std::int64_t seq = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (RobotMessage& m : batch) m = telemetry(robot, ++seq);
    state.ResumeTiming();
    adit::StatusOr<std::size_t> r = db->appendMessages(batch);
    if (!r.ok() || *r != batch_size) return state.SkipWithError("append failed");
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(batch_size));
}

void BM_ReplayHistory1000(benchmark::State& state, const std::string& backend) {
  std::string why;
  Store* db = storeFor(backend, why);
  if (!db) return state.SkipWithError(why.c_str());
  const std::string robot = freshRobot();
  std::vector<RobotMessage> all;
  for (std::int64_t s = 1; s <= 1000; ++s) all.push_back(telemetry(robot, s));
  if (!db->appendMessages(all).ok()) return state.SkipWithError("setup failed");
  for (auto _ : state) {
    adit::StatusOr<std::vector<RobotMessage>> h = db->history(robot, 1, 1000);
    if (!h.ok() || h->size() != 1000) return state.SkipWithError("replay failed");
    benchmark::DoNotOptimize(h->back().pose->x);
  }
  state.SetItemsProcessed(state.iterations() * 1000);
}

BENCHMARK_CAPTURE(BM_AppendOnePerTransaction, sqlite, std::string("sqlite"))->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_AppendOnePerTransaction, postgresql, std::string("postgresql"))->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_AppendBatch, sqlite, std::string("sqlite"))->Arg(10)->Arg(50)->Arg(500)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_AppendBatch, postgresql, std::string("postgresql"))->Arg(10)->Arg(50)->Arg(500)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_ReplayHistory1000, sqlite, std::string("sqlite"))->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_ReplayHistory1000, postgresql, std::string("postgresql"))->UseRealTime()->Unit(benchmark::kMicrosecond);

/// Rows per second of every run, and the ratios between runs of this process at the end.
class RateReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      const auto it = r.counters.find("items_per_second");
      if (!r.error_occurred && it != r.counters.end()) rate_[r.benchmark_name()] = it->second;
    }
  }
  void printRatios() const {
    auto ratio = [&](const std::string& num, const std::string& den, const char* what) {
      const auto a = rate_.find(num), b = rate_.find(den);
      if (a == rate_.end() || b == rate_.end()) return;
      std::printf("  %-58s %8.1fx  (%.0f vs %.0f rows/s)\n", what, a->second / b->second, a->second, b->second);
    };
    std::printf("\nRows per second, ratios measured in this run:\n");
    for (const char* backend : {"sqlite", "postgresql"}) {
      const std::string one = std::string("BM_AppendOnePerTransaction/") + backend + "/real_time";
      for (const char* n : {"10", "50", "500"}) {
        const std::string what = std::string(backend) + ": batch of " + n + " / one message per transaction";
        ratio(std::string("BM_AppendBatch/") + backend + "/" + n + "/real_time", one, what.c_str());
      }
    }
    ratio("BM_AppendOnePerTransaction/sqlite/real_time", "BM_AppendOnePerTransaction/postgresql/real_time",
          "one per transaction: sqlite / postgresql");
  }

 private:
  std::map<std::string, double> rate_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RateReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.printRatios();
  benchmark::Shutdown();
  return 0;
}
