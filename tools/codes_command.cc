// `simplexdb codes` (the JSON-lines contract of DESIGN.md, read by outside
// checks) and `simplexdb inspect` (the same facts for people).
#include <cctype>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "hierarchy/ht_neighbors.h"
#include "hierarchy/simplex_code.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

// Keys in the order the contract lists them.
using json = nlohmann::ordered_json;

enum class Hierarchy { kHT };

const std::map<std::string, Hierarchy> kHierarchyNames = {{"ht", Hierarchy::kHT}};

template <int D>
json CodeOrNull(SimplexCode<D> c) {
  return c.is_none() ? json(nullptr) : json(c.ToString());
}

template <int D>
double UnitCoordinate(int32_t x) {
  return static_cast<double>(x) / static_cast<double>(kDomainSide<D>);
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
  j["parent"] = code.level() > 0 ? json(code.parent().ToString()) : json(nullptr);
  // A code at the maximum level has no children in the 64-bit key.
  if (code.level() < SimplexCode<D>::kMaxLevel) {
    j["children"] = {code.child(0).ToString(), code.child(1).ToString()};
  } else {
    j["children"] = nullptr;
  }
  json cluster = json::array();
  for (const SimplexCode<D> m : Cluster(code)) cluster.push_back(m.ToString());
  j["cluster"] = std::move(cluster);
  return j;
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

template <int D>
void RunCodes() {
  std::string line;
  size_t line_number = 0;
  size_t bad = 0;
  while (std::getline(std::cin, line)) {
    ++line_number;
    const std::string_view text = Trim(line);
    if (text.empty()) continue;
    const Result<SimplexCode<D>> code = SimplexCode<D>::Parse(text);
    if (!code.ok()) {
      // Keep the output aligned with the input: one object per code line.
      ++bad;
      const std::string why = std::string(code.status().message());
      std::cout << json{{"code", std::string(text)}, {"error", why}}.dump() << '\n';
      std::cerr << fmt::format("simplexdb codes: line {}: {}\n", line_number, why);
      continue;
    }
    std::cout << DescribeJson(*code).dump() << '\n';
  }
  std::cout.flush();
  if (bad > 0) {
    throw CommandError(fmt::format("codes: {} of the input lines were not location codes",
                                   bad));
  }
}

// --- inspect ---------------------------------------------------------------

std::string ShapeName(TetCode c) {
  static const char* kShapes[] = {"1/8 pyramid", "1/2 pyramid", "1/4 pyramid"};
  return kShapes[c.level() % 3];
}

std::string EdgeAlignment(const Point<3>& a, const Point<3>& b) {
  int nonzero = 0;
  for (int i = 0; i < 3; ++i) nonzero += a[i] != b[i];
  return nonzero == 1 ? "axis-aligned" : nonzero == 2 ? "plane-aligned" : "non-aligned";
}

std::string FormatPoint(const Point<3>& p) {
  return fmt::format("({}, {}, {})", UnitCoordinate<3>(p[0]), UnitCoordinate<3>(p[1]),
                     UnitCoordinate<3>(p[2]));
}

void InspectTet(TetCode code) {
  static const char* kFaces[] = {"v1v2v3", "v1v2v4", "v1v3v4", "v2v3v4"};
  const SimplexVertices<3> v = Vertices(code);
  fmt::print("{}: level {}, a {} under root {}\n", code.ToString(), code.level(),
             ShapeName(code), code.top());
  for (int i = 0; i < 4; ++i) fmt::print("  v{}  {}\n", i + 1, FormatPoint(v[i]));
  fmt::print("  splits v3v4 ({} edge) at {}\n", EdgeAlignment(v[2], v[3]),
             FormatPoint(Point<3>{(v[2][0] + v[3][0]) / 2, (v[2][1] + v[3][1]) / 2,
                                  (v[2][2] + v[3][2]) / 2}));
  fmt::print("  parent    {}\n", code.level() > 0 ? code.parent().ToString() : "none (a root)");
  if (code.level() < TetCode::kMaxLevel) {
    fmt::print("  children  {}  {}\n", code.child(0).ToString(), code.child(1).ToString());
  }
  for (int k = 1; k <= 4; ++k) {
    const TetCode n = Neighbor(code, k);
    fmt::print("  neighbor type {} (face {})  {}\n", k, kFaces[k - 1],
               n.is_none() ? "none: the face is on the cube's boundary" : n.ToString());
  }
  const TetCluster cluster = Cluster(code);
  fmt::print("  cluster: {} tetrahedra share the split edge:", cluster.size());
  for (const TetCode m : cluster) fmt::print(" {}", m.ToString());
  fmt::print("\n");
}

}  // namespace

void RegisterCodesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "codes",
      "Describe location codes read from stdin, one per line, as JSON lines:\n"
      "{\"code\",\"level\",\"vertices\" (unit-cube coordinates, v1 first),\n"
      "\"neighbors\" (face types 1..D+1, null on the domain boundary),\n"
      "\"parent\",\"children\",\"cluster\"}. A line that is not a code gets\n"
      "{\"code\",\"error\"} and the exit status is 1.");
  auto hierarchy = std::make_shared<Hierarchy>(Hierarchy::kHT);
  cmd->add_option("--hierarchy", *hierarchy, "ht: Hierarchy of Tetrahedra")
      ->required()
      ->transform(CLI::CheckedTransformer(kHierarchyNames, CLI::ignore_case));
  cmd->callback([hierarchy] {
    switch (*hierarchy) {
      case Hierarchy::kHT: RunCodes<3>(); break;
    }
  });
}

void RegisterInspectCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "inspect",
      "Explain location codes for people: shape, vertices, split edge,\n"
      "parent and children, face neighbors and cluster.\n"
      "Example: simplexdb inspect --hierarchy ht 2:10011");
  auto hierarchy = std::make_shared<Hierarchy>(Hierarchy::kHT);
  auto codes = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--hierarchy", *hierarchy, "ht: Hierarchy of Tetrahedra")
      ->transform(CLI::CheckedTransformer(kHierarchyNames, CLI::ignore_case))
      ->default_str("ht");
  cmd->add_option("codes", *codes, "location codes T:bits")->required();
  cmd->callback([hierarchy, codes] {
    for (const std::string& text : *codes) {
      const Result<TetCode> code = TetCode::Parse(text);
      if (!code.ok()) throw CommandError(std::string(code.status().message()));
      InspectTet(*code);
    }
  });
}

}  // namespace simplexdb::tools
