// SPDX-License-Identifier: BSD-3-Clause
// The campaign model (adit/sim/campaign.hpp) without the CLI: identities round-trip through JSON
// and refuse what is not theirs, statistics merge exactly in any order and grouping, and a
// shard's CSV is checked row by row (the CLI scripts in tests/tools cover the files end to end).
#include "adit/sim/campaign.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

namespace adit::sim {
namespace {

CampaignIdentity identity(int scenarios = 10, int shards = 3) {
  CampaignIdentity id;
  id.map = "maps/district.yaml";
  id.map_hash = "sha256:0123";
  id.seed = 0xFFFFFFFFFFFFFFF1ull;  // a seed above 2^63 must survive JSON
  id.scenarios = scenarios;
  id.shards = shards;
  id.adit_version = "1.0.0";
  id.adit_commit = "abc";
  return id;
}

// A row of scenario `index` as a run might give it; `variant` varies the outcome and figures.
BatchRunResult row(const CampaignIdentity& id, int index, int variant) {
  BatchRunResult r;
  r.index = index;
  r.seed = batchRunSeed(id.seed, index);
  const char* outcomes[] = {"arrived", "arrived", "timeout", "collision", "arrived", "no_route"};
  r.outcome = outcomes[variant % 6];
  r.arrival_time_s = r.outcome == std::string("arrived") ? 50.0 + 7.3 * variant : std::nan("");
  r.path_length_m = 100.0 + 1.7 * variant;
  r.min_clearance_m = 0.2 + 0.01 * variant;
  r.collisions = r.outcome == std::string("collision") ? 2 : 0;
  r.replans = variant % 3;
  r.step_p50_us = 3.0 + variant;
  r.step_p99_us = 40.0 * (1 + variant);
  r.final_goal_distance_m = r.outcome == std::string("arrived") ? 0.1 : 20.0;
  r.end_cause = r.outcome == std::string("timeout") ? EndCause::kRouteOutlastsTime : EndCause::kNone;
  return r;
}

TEST(CampaignModel, IdentityRoundTripsThroughJson) {
  const CampaignIdentity id = identity();
  // As a shard's JSON holds it.
  const nlohmann::json j = nlohmann::json::parse(nlohmann::ordered_json{{"campaign", campaignIdentityJson(id)}}.dump());
  const StatusOr<CampaignIdentity> back = campaignIdentityFromJson(j, "shard.json");
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->seed, id.seed);
  EXPECT_EQ(back->scenarios, id.scenarios);
  EXPECT_EQ(back->shards, id.shards);
  EXPECT_EQ(back->map_hash, id.map_hash);
  EXPECT_EQ(campaignIdentityJson(*back).dump(), campaignIdentityJson(id).dump());
}

TEST(CampaignModel, IdentityRefusesFloatsWrapsAndMoreShardsThanScenarios) {
  const nlohmann::json good =
      nlohmann::json::parse(nlohmann::ordered_json{{"campaign", campaignIdentityJson(identity())}}.dump());
  ASSERT_TRUE(campaignIdentityFromJson(good, "shard.json").ok());
  auto refused = [&](const char* key, const nlohmann::json& value) {
    nlohmann::json j = good;
    j["campaign"][key] = value;
    const StatusOr<CampaignIdentity> r = campaignIdentityFromJson(j, "shard.json");
    EXPECT_FALSE(r.ok()) << key << " = " << value.dump();
    if (!r.ok()) {
      EXPECT_NE(r.status().message().find("shard.json"), std::string::npos) << r.status().message();
      EXPECT_NE(r.status().message().find(key), std::string::npos) << r.status().message();
    }
  };
  refused("seed", 1.5);
  refused("seed", -1);
  refused("scenarios", 2.0);
  refused("scenarios", 0);
  refused("shards", 11);  // M > N
  refused("shards", 0);
  nlohmann::json missing = good;
  missing["campaign"].erase("map_hash");
  EXPECT_FALSE(campaignIdentityFromJson(missing, "shard.json").ok());
}

// Two shards belong to one campaign when nothing but the map's path and the build differ.
TEST(CampaignModel, IdentityDifferencesNameEachField) {
  const CampaignIdentity a = identity();
  CampaignIdentity b = a;
  b.map = "elsewhere/district.yaml";
  b.adit_commit = "another build";
  EXPECT_TRUE(campaignIdentityDifferences(a, b).empty());
  b.seed = a.seed + 1;
  b.shards = a.shards + 1;
  const std::vector<std::string> d = campaignIdentityDifferences(a, b);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0], "seed (" + std::to_string(b.seed) + " vs " + std::to_string(a.seed) + ")");
  EXPECT_EQ(d[1], "shards (" + std::to_string(b.shards) + " vs " + std::to_string(a.shards) + ")");
}

TEST(CampaignModel, ShardsPartitionTheScenarios) {
  for (int n : {1, 7, 10, 1000})
    for (int m = 1; m <= std::min(n, 9); ++m) {
      long long sum = 0;
      for (int k = 0; k < m; ++k) sum += shardScenarioCount(k, m, n);
      EXPECT_EQ(sum, n) << n << " scenarios in " << m << " shards";
    }
  EXPECT_EQ(shardName(2, 5, ".csv"), "shard-2-of-5.csv");
}

TEST(CampaignModel, StatisticsMergeExactlyInAnyOrderAndGrouping) {
  const CampaignIdentity id = identity(60, 4);
  std::vector<BatchRunResult> rows;
  for (int i = 0; i < 60; ++i) rows.push_back(row(id, i, i * 7 % 11));
  CampaignStats whole;
  for (const BatchRunResult& r : rows) ASSERT_TRUE(whole.add(r).ok());
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    std::shuffle(rows.begin(), rows.end(), rng);
    std::vector<CampaignStats> parts(1 + trial);
    for (std::size_t i = 0; i < rows.size(); ++i) ASSERT_TRUE(parts[i % parts.size()].add(rows[i]).ok());
    CampaignStats merged;
    for (const CampaignStats& p : parts) ASSERT_TRUE(merged.add(p).ok());
    EXPECT_EQ(merged.toJson().dump(), whole.toJson().dump()) << "trial " << trial;
  }
  EXPECT_EQ(whole.scenarios, 60);
  EXPECT_EQ(whole.outcomes.at("arrived") + whole.outcomes.at("timeout") + whole.outcomes.at("collision") +
                whole.outcomes.at("no_route"),
            60);
}

TEST(CampaignModel, AShardCsvIsCheckedRowByRow) {
  const CampaignIdentity id = identity(10, 3);
  const int k = 1;  // indices 1, 4, 7
  auto csv = [&](const std::vector<BatchRunResult>& rows) {
    std::string text = std::string(batchCsvHeader()) + "\n";
    for (const BatchRunResult& r : rows) text += batchCsvRow(r) + "\n";
    return text;
  };
  const std::vector<BatchRunResult> mine = {row(id, 1, 0), row(id, 4, 2), row(id, 7, 3)};
  const StatusOr<ShardRows> ok = readShardRows(csv(mine), "s.csv", id, k);
  ASSERT_TRUE(ok.ok()) << ok.status().message();
  EXPECT_EQ(ok->rows.size(), 3u);
  EXPECT_EQ(ok->stats.scenarios, 3);
  EXPECT_EQ(ok->stats.outcomes.at("collision"), 1);

  auto refusedWith = [&](std::vector<BatchRunResult> rows, const char* what) {
    const StatusOr<ShardRows> r = readShardRows(csv(rows), "s.csv", id, k);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_NE(r.status().message().find("s.csv"), std::string::npos) << what << ": " << r.status().message();
  };
  std::vector<BatchRunResult> other_shard = mine;
  other_shard[1] = row(id, 5, 2);  // index 5 is shard 2's
  refusedWith(other_shard, "another shard's index");
  std::vector<BatchRunResult> wrong_seed = mine;
  wrong_seed[2].seed ^= 1;
  refusedWith(wrong_seed, "a seed the campaign seed does not give");
  std::vector<BatchRunResult> twice = mine;
  twice[2] = mine[0];
  refusedWith(twice, "an index twice");
  refusedWith({mine[0], mine[1]}, "a row missing");
}

TEST(CampaignModel, ASummaryThatDisagreesWithItsRowsIsRefusedByField) {
  const CampaignIdentity id = identity(4, 1);
  std::string text = std::string(batchCsvHeader()) + "\n";
  std::vector<nlohmann::ordered_json> failures;
  for (int i = 0; i < 4; ++i) {
    const BatchRunResult r = row(id, i, i + 2);
    text += batchCsvRow(r) + "\n";
    if (isFailure(r)) failures.push_back(failureEntry(r));
  }
  const StatusOr<ShardRows> rows = readShardRows(text, "s.csv", id, 0);
  ASSERT_TRUE(rows.ok()) << rows.status().message();
  nlohmann::ordered_json shard;
  shard["stats"] = rows->stats.toJson();
  shard["failures"] = failures;
  const nlohmann::json as_read = nlohmann::json::parse(shard.dump());
  const auto listed = checkShardSummary(as_read, *rows, "s.json");
  ASSERT_TRUE(listed.ok()) << listed.status().message();
  EXPECT_EQ(listed->size(), failures.size());

  nlohmann::json edited = as_read;
  edited["stats"]["counts"]["outcomes"]["arrived"] = edited["stats"]["counts"]["outcomes"]["arrived"].get<long long>() + 1;
  const auto refused = checkShardSummary(edited, *rows, "s.json");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("s.json"), std::string::npos) << refused.status().message();
  EXPECT_NE(refused.status().message().find("arrived"), std::string::npos) << refused.status().message();
}

}  // namespace
}  // namespace adit::sim
