// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/mesh.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <pugixml.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>

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

// Assimp's COLLADA importer reads every <accessor> from its source array without checking that
// the array holds offset + count x stride values (a float_array without `count` holds none, and
// the read dereferences null). The arrays and accessors are sized here first, with pugixml, with
// the same attribute parsing Assimp uses.
Status checkDae(const std::string& b, const std::string& name) {
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(b.data(), b.size());
  if (!parsed) return invalidArgument(at(name, std::uint64_t(parsed.offset)) + ": not XML: " + parsed.description());
  std::map<std::string, std::uint64_t> array_values;  // id -> values Assimp keeps (its `count`)
  for (const pugi::xpath_node& n :
       doc.select_nodes("//float_array | //int_array | //Name_array | //IDREF_array | //bool_array"))
    array_values[n.node().attribute("id").as_string()] = n.node().attribute("count").as_uint();
  for (const pugi::xpath_node& n : doc.select_nodes("//accessor")) {
    const pugi::xml_node acc = n.node();
    std::string source = acc.attribute("source").as_string();
    if (!source.empty() && source[0] == '#') source.erase(0, 1);
    const auto it = array_values.find(source);
    if (it == array_values.end()) continue;  // an unresolved reference is left to Assimp
    const std::uint64_t count = acc.attribute("count").as_uint(), offset = acc.attribute("offset").as_uint();
    const auto params = acc.children("param");  // Assimp reads a component per param, even past stride
    const std::uint64_t stride = std::max<std::uint64_t>(
        {acc.attribute("stride").as_uint(1), std::uint64_t(std::distance(params.begin(), params.end())), 1});
    if (count > 0 && offset + count * stride > it->second)
      return invalidArgument(at(name, std::uint64_t(std::max<std::ptrdiff_t>(acc.offset_debug(), 0))) + ": accessor of '" +
                             source + "' reads " + std::to_string(count) + " x " + std::to_string(stride) + " values from offset " +
                             std::to_string(offset) + " but the array holds " + std::to_string(it->second));
  }
  // Primitives: <p> must hold exactly the indices the element announces. Each vertex takes one
  // index per input offset; triangles take 3 vertices, lines 2, a polylist its <vcount>s.
  for (const pugi::xpath_node& n : doc.select_nodes(
           "//triangles | //lines | //polylist | //polygons | //trifans | //tristrips | //linestrips")) {
    const pugi::xml_node prim = n.node();
    std::uint64_t inputs = 1;
    for (const pugi::xml_node& in : prim.children("input"))
      inputs = std::max<std::uint64_t>(inputs, std::uint64_t(in.attribute("offset").as_uint()) + 1);
    // Index count of a <p>, or none when a token is not a non-negative integer (on such a token
    // Assimp allocated gigabytes).
    const auto tokens = [](const pugi::xml_node& node) -> std::optional<std::uint64_t> {
      std::istringstream is(node.child_value());
      std::uint64_t k = 0;
      for (std::string t; is >> t; ++k)
        if (t.size() > 10 || t.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
      return k;
    };
    const std::string kind = prim.name();
    std::uint64_t expected = 0;
    if (kind == "triangles" || kind == "lines")
      expected = std::uint64_t(prim.attribute("count").as_uint()) * (kind == "lines" ? 2 : 3) * inputs;
    if (kind == "polylist") {
      std::istringstream is(prim.child("vcount").child_value());
      for (std::uint64_t v; is >> v;) expected += v * inputs;
    }
    std::uint64_t given = 0;
    for (const pugi::xml_node& p : prim.children("p")) {
      const std::optional<std::uint64_t> k = tokens(p);
      const std::string where = at(name, std::uint64_t(std::max<std::ptrdiff_t>(p.offset_debug(), 0))) + ": <" + kind + "> <p>";
      if (!k) return invalidArgument(where + " holds something other than vertex indices");
      if (*k % inputs != 0 || (expected == 0 && *k < 2 * inputs))
        return invalidArgument(where + " holds " + std::to_string(*k) + " indices, not whole vertices of " +
                               std::to_string(inputs) + " inputs");
      given += *k;
    }
    if (expected != 0 && given != expected)
      return invalidArgument(at(name, std::uint64_t(std::max<std::ptrdiff_t>(prim.offset_debug(), 0))) + ": <" + kind +
                             "> announces " + std::to_string(expected) + " indices, its <p> holds " + std::to_string(given));
  }
  return {};
}

// A face without indices is refused; each mesh's primitive types are recomputed from its faces,
// since Assimp's triangulation asserts that they are right rather than checking it.
Status checkFaces(const aiScene& scene, const std::string& name) {
  for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
    aiMesh* mesh = scene.mMeshes[m];
    unsigned types = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const unsigned n = mesh->mFaces[f].mNumIndices;
      if (n == 0)
        return invalidArgument(name + ": face " + std::to_string(f + 1) + " of mesh " + std::to_string(m + 1) +
                               " has no vertex indices");
      types |= n == 1 ? aiPrimitiveType_POINT : n == 2 ? aiPrimitiveType_LINE : n == 3 ? aiPrimitiveType_TRIANGLE
                                                                                       : aiPrimitiveType_POLYGON;
    }
    mesh->mPrimitiveTypes = types;
  }
  return {};
}

}  // namespace

StatusOr<Geometry> parseMesh(const std::string& bytes, const std::string& name, const std::string& hint,
                             const ReadLimits& limits) {
  if (bytes.empty()) return invalidArgument(name + ": empty file");
  if (hint == "stl") ADIT_RETURN_IF_ERROR(checkStl(bytes, name, limits));
  if (hint == "dae") ADIT_RETURN_IF_ERROR(checkDae(bytes, name));
  Assimp::Importer importer;
  // Points and lines are not walls; drop them so only triangles remain.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  // Decode first, post-process after checkFaces(): Debian's Assimp aborts in its triangulation
  // (ai_assert) on a face without indices, which its validation lets through.
  const aiScene* scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(), aiProcess_ValidateDataStructure,
                                                     hint.c_str());
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    return invalidArgument(name + ": cannot read the " + hint + " mesh: " + importer.GetErrorString());
  ADIT_RETURN_IF_ERROR(checkFaces(*scene, name));
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_PreTransformVertices |
                                       aiProcess_ValidateDataStructure);
  if (!scene) return invalidArgument(name + ": cannot read the " + hint + " mesh: " + importer.GetErrorString());
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
