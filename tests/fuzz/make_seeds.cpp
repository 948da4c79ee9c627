// SPDX-License-Identifier: BSD-3-Clause
// Writes the fuzzers' seed corpora from the repository's own data: small .bt/.ot maps voxelized
// from the test surveys and cut from maps/district.bt, the survey YAML files, the points CSVs.
// Usage: adit_fuzz_seeds MAPS_DIR TOOLS_DATA_DIR OUT_DIR  (writes OUT_DIR/<fuzzer>/...)
#include <cstdio>
#include <filesystem>
#include <string>

#include "adit/map/map_io.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"

namespace fs = std::filesystem;
using namespace adit::map;

namespace {

constexpr std::uintmax_t kMaxSeedBytes = 16 * 1024;

bool ok(const adit::Status& s, const std::string& what) {
  if (!s.ok()) std::fprintf(stderr, "adit_fuzz_seeds: %s: %s\n", what.c_str(), s.message().c_str());
  return s.ok();
}

// Both OctoMap formats of `map`, as <stem>.bt and <stem>.ot.
bool writeBoth(const OccupancyMap& map, const fs::path& dir, const std::string& stem) {
  return ok(writeOctomap(map, (dir / (stem + ".bt")).string()), stem) &&
         ok(writeOctomap(map, (dir / (stem + ".ot")).string()), stem);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s MAPS_DIR TOOLS_DATA_DIR OUT_DIR\n", argv[0]);
    return 2;
  }
  const fs::path maps = argv[1], data = argv[2], out = argv[3];
  const fs::path octomap = out / "octomap", survey = out / "survey", csv = out / "points_csv";
  for (const fs::path& d : {octomap, survey, csv}) fs::create_directories(d);
  bool good = true;

  // Surveys and CSVs as they are; the YAML ones also voxelized coarsely into small octrees.
  for (const fs::path& dir : {maps, data})
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string ext = e.path().extension().string();
      if (ext == ".yaml") {
        fs::copy_file(e.path(), survey / e.path().filename(), fs::copy_options::overwrite_existing);
        adit::StatusOr<SurveyNetwork> net = loadSurvey(e.path().string());
        if (!net.ok()) continue;  // the malformed examples are seeds for the survey fuzzer only
        for (double res : {1.0, 0.5}) {
          net->resolution_m = res;
          net->rock_shell_m = res;
          if (net->estimatedVoxels() > 2e6) continue;
          adit::StatusOr<OccupancyMap> map = voxelize(*net);
          good = ok(map.status(), e.path().string()) && good;
          if (map.ok())
            good = writeBoth(*map, octomap, e.path().stem().string() + "_" + std::to_string(int(res * 10))) && good;
        }
      } else if (ext == ".csv") {
        fs::copy_file(e.path(), csv / e.path().filename(), fs::copy_options::overwrite_existing);
      } else if (ext == ".bt" && fs::file_size(e.path()) < 4096) {
        fs::copy_file(e.path(), octomap / e.path().filename(), fs::copy_options::overwrite_existing);
      }
    }

  // Small pieces of the bundled district: a straight roadway and a junction.
  adit::StatusOr<OccupancyMap> district = loadMap((maps / "district.bt").string());
  if (ok(district.status(), "district.bt")) {
    const Aabb pieces[] = {Aabb(Vec3(10, -3, -1), Vec3(13, 3, 4)), Aabb(Vec3(-4, -4, -1), Vec3(4, 4, 4))};
    for (int i = 0; i < 2; ++i) {
      adit::StatusOr<OccupancyMap> part = cropMap(*district, pieces[i]);
      if (ok(part.status(), "district crop")) good = writeBoth(*part, octomap, "district_piece" + std::to_string(i)) && good;
    }
  }
  // Large seeds slow every execution down (libFuzzer mutates whole inputs): keep the small ones.
  for (const fs::path& dir : {octomap, survey, csv})
    for (const auto& e : fs::directory_iterator(dir))
      if (fs::file_size(e.path()) > kMaxSeedBytes) fs::remove(e.path());
  return good ? 0 : 1;
}
