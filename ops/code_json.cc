// The codes contract's lines (ops/code_json.h), moved here from
// tools/codes_command.cc so the Python package builds the same objects.
#include "ops/code_json.h"

#include <utility>

#include <nlohmann/json.hpp>

#include "hierarchy/cluster.h"
#include "hierarchy/neighbors.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_neighbors.h"

namespace simplexdb {
namespace {

// Keys in the order the contract lists them.
using json = nlohmann::ordered_json;

template <class Code>
json CodeOrNull(Code c) {
  return c.is_none() ? json(nullptr) : json(c.ToString());
}

// The "parent" and "children" of a line: null for a root's parent, and for
// the children of a code at the maximum level (no deeper level fits in the
// 64-bit key).
template <class Code>
void AddParentAndChildren(json& j, Code code, int children) {
  j["parent"] = code.level() > 0 ? json(code.parent().ToString()) : json(nullptr);
  if (code.level() < Code::kMaxLevel) {
    json list = json::array();
    for (int i = 0; i < children; ++i) list.push_back(code.child(i).ToString());
    j["children"] = std::move(list);
  } else {
    j["children"] = nullptr;
  }
}

// One line of the `codes` contract.
template <int D>
json DescribeJson(SimplexCode<D> code) {
  json j;
  j["code"] = code.ToString();
  j["level"] = code.level();
  json vertices = json::array();
  for (const Point<D>& p : Vertices(code)) {
    json xyz = json::array();
    for (int32_t x : p) xyz.push_back(UnitCoordinate<D>(x));
    vertices.push_back(std::move(xyz));
  }
  j["vertices"] = std::move(vertices);
  json neighbors = json::array();
  for (int k = 1; k <= D + 1; ++k) neighbors.push_back(CodeOrNull(Neighbor(code, k)));
  j["neighbors"] = std::move(neighbors);
  AddParentAndChildren(j, code, 2);
  json cluster = json::array();
  for (const SimplexCode<D> m : Cluster(code)) cluster.push_back(m.ToString());
  j["cluster"] = std::move(cluster);
  return j;
}

// One line of the `codes` contract for a triangle quadtree: vertices
// (apex, left, right) on the solid inscribed in the unit sphere, neighbors
// left, right, vertical (a closed surface: never null), four children, no
// cluster (triangles are not bisected).
template <Polyhedron P>
json DescribeJson(TriCode<P> code) {
  json j;
  j["code"] = code.ToString();
  j["level"] = code.level();
  json vertices = json::array();
  for (const Vec3& p : PolyhedronVertices(code)) vertices.push_back({p[0], p[1], p[2]});
  j["vertices"] = std::move(vertices);
  json neighbors = json::array();
  for (int d = 0; d < kTriDirections; ++d) {
    neighbors.push_back(CodeOrNull(TriNeighbor(code, static_cast<TriDirection>(d))));
  }
  j["neighbors"] = std::move(neighbors);
  AddParentAndChildren(j, code, 4);
  j["cluster"] = json::array();
  return j;
}

}  // namespace

std::string CodeJson(TetCode code) { return DescribeJson(code).dump(); }
std::string CodeJson(PentaCode code) { return DescribeJson(code).dump(); }
std::string CodeJson(IcosaCode code) { return DescribeJson(code).dump(); }
std::string CodeJson(OctaCode code) { return DescribeJson(code).dump(); }
std::string CodeJson(TetraCode code) { return DescribeJson(code).dump(); }

namespace {

template <class Code>
Result<std::string> ParseAndDescribe(std::string_view text) {
  SDB_ASSIGN_OR_RETURN(const Code code, Code::Parse(text));
  return CodeJson(code);
}

}  // namespace

Result<std::string> DescribeCode(std::string_view hierarchy, std::string_view text) {
  if (hierarchy == "ht") return ParseAndDescribe<TetCode>(text);
  if (hierarchy == "hp") return ParseAndDescribe<PentaCode>(text);
  if (hierarchy == "tri-icosahedron") return ParseAndDescribe<IcosaCode>(text);
  if (hierarchy == "tri-octahedron") return ParseAndDescribe<OctaCode>(text);
  if (hierarchy == "tri-tetrahedron") return ParseAndDescribe<TetraCode>(text);
  return Status::InvalidArgument("hierarchy '" + std::string(hierarchy) +
                                 "': expected ht, hp, tri-icosahedron, tri-octahedron or "
                                 "tri-tetrahedron");
}

}  // namespace simplexdb
