// SPDX-License-Identifier: BSD-3-Clause
// A campaign shard as `adit campaign merge` reads it (issue 17): the input is the shard's JSON, a
// line "#csv", then its CSV. Identity, rows and summary go through the merge's own checks
// (adit/sim/campaign.hpp; the SHA-256 comparison is left out so that the fuzzer reaches the
// rows). Whatever passes must be self-consistent: every accepted row prints back to the same
// text, and the statistics recomputed from the printed rows are the ones accepted.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "adit/sim/campaign.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t cut = input.find("\n#csv\n");
  if (cut == std::string::npos) return 0;
  const nlohmann::json j = nlohmann::json::parse(input.substr(0, cut), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return 0;
  const adit::StatusOr<adit::sim::CampaignIdentity> id = adit::sim::campaignIdentityFromJson(j, "fuzz.json");
  if (!id.ok()) return 0;
  // The shard index as merge reads it: an integer in 0..M-1.
  if (!j.contains("shard") || !j["shard"].is_object() || !j["shard"].contains("index") ||
      !j["shard"]["index"].is_number_integer())
    return 0;
  const long long k = j["shard"]["index"].get<long long>();
  if (k < 0 || k >= id->shards) return 0;
  const std::string csv = input.substr(cut + 6);
  adit::StatusOr<adit::sim::ShardRows> rows = adit::sim::readShardRows(csv, "fuzz.csv", *id, int(k));
  if (!rows.ok()) return 0;
  adit::sim::CampaignStats again;
  for (std::size_t i = 0; i < rows->rows.size(); ++i) {
    const std::string printed = adit::sim::batchCsvRow(rows->rows[i]);
    adit::StatusOr<adit::sim::BatchRunResult> back = adit::sim::parseBatchCsvRow(printed);
    if (!back.ok()) std::abort();  // an accepted row must print as a row
    if (!again.add(*back).ok()) std::abort();
  }
  if (again.toJson() != rows->stats.toJson()) std::abort();
  (void)adit::sim::checkShardSummary(j, *rows, "fuzz.json");
  return 0;
}
