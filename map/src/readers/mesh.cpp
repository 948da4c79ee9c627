// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/mesh.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>

#include "adit/map/map_io.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

namespace {

Status checkStl(const std::string& b, const std::string& name, const ReadLimits& limits) {
  if (b.size() >= 84) {
    const std::uint64_t n = loadLE<std::uint32_t>(b, 80);
    if (84 + 50 * n == b.size()) {
      if (n > limits.max_points) return outOfRange(at(name, 80) + ": " + std::to_string(n) + " triangles exceed the limit");
      if (n == 0) return invalidArgument(at(name, 80) + ": binary STL with no triangles");
      return {};
    }
  }
  if (b.compare(0, 5, "solid") == 0 && b.find("facet") != std::string::npos) return {};  // ascii
  if (b.size() < 84) return dataLoss(name + ": truncated STL (" + std::to_string(b.size()) + " bytes, no header)");
  const std::uint64_t n = loadLE<std::uint32_t>(b, 80);
  return dataLoss(at(name, 80) + ": binary STL header says " + std::to_string(n) + " triangles (" +
                  std::to_string(84 + 50 * n) + " bytes) but the file has " + std::to_string(b.size()) + " bytes");
}

}  // namespace

StatusOr<Geometry> parseMesh(const std::string& bytes, const std::string& name, const std::string& hint,
                             const ReadLimits& limits) {
  if (bytes.empty()) return invalidArgument(name + ": empty file");
  if (hint == "stl") ADIT_RETURN_IF_ERROR(checkStl(bytes, name, limits));
  Assimp::Importer importer;
  // Points and lines are not walls; drop them so only triangles remain.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer.ReadFileFromMemory(
      bytes.data(), bytes.size(),
      aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_PreTransformVertices | aiProcess_ValidateDataStructure,
      hint.c_str());
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    return invalidArgument(name + ": cannot read the " + hint + " mesh: " + importer.GetErrorString());
  Geometry g;
  std::uint64_t nv = 0, nt = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    nv += scene->mMeshes[m]->mNumVertices;
    nt += scene->mMeshes[m]->mNumFaces;
  }
  if (nv > limits.max_points || nt > limits.max_points)
    return outOfRange(name + ": " + std::to_string(nv) + " vertices / " + std::to_string(nt) +
                      " triangles exceed the limit of " + std::to_string(limits.max_points));
  g.points.reserve(nv);
  g.triangles.reserve(nt);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    const std::uint32_t base = std::uint32_t(g.points.size());
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      g.points.emplace_back(double(p.x), double(p.y), double(p.z));
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      g.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  if (g.triangles.empty()) return invalidArgument(name + ": the mesh has no triangles");
  const std::int64_t bad = firstNonFinite(g.points);
  if (bad >= 0) return invalidArgument(name + ": vertex " + std::to_string(bad + 1) + " has a non-finite coordinate");
  return g;
}

StatusOr<Geometry> readMesh(const std::string& path, const ReadLimits& limits) {
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  std::string ext = extensionOf(path);
  return parseMesh(bytes, path, ext.empty() ? ext : ext.substr(1), limits);
}

}  // namespace adit::map
