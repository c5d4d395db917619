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
#include "hierarchy/neighbors.h"
#include "hierarchy/simplex_code.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

// Keys in the order the contract lists them.
using json = nlohmann::ordered_json;

enum class Hierarchy { kHT, kHP };

const std::map<std::string, Hierarchy> kHierarchyNames = {{"ht", Hierarchy::kHT},
                                                          {"hp", Hierarchy::kHP}};
constexpr const char* kHierarchyHelp =
    "ht: Hierarchy of Tetrahedra (3D); hp: Hierarchy of Pentatopes (4D)";

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

template <int D>
std::string ShapeName(SimplexCode<D> c) {
  if constexpr (D == 3) {
    static const char* kShapes[] = {"1/8 pyramid", "1/2 pyramid", "1/4 pyramid"};
    return kShapes[c.level() % 3];
  } else {
    static const char* kShapes[] = {"h-pentatope", "c-pentatope", "s-pentatope", "e-pentatope"};
    return kShapes[c.level() % 4];
  }
}

// How many coordinates an edge moves along: 1 is axis-aligned, D is the
// diagonal of a cube (hypercube).
template <int D>
std::string EdgeAlignment(const Point<D>& a, const Point<D>& b) {
  int moved = 0;
  for (int i = 0; i < D; ++i) moved += a[i] != b[i];
  if (moved == 1) return "axis-aligned";
  if (moved == D) return "a main diagonal";
  return fmt::format("a diagonal of a {}-dimensional face", moved);
}

template <int D>
std::string FormatPoint(const Point<D>& p) {
  std::string s = "(";
  for (int i = 0; i < D; ++i) s += fmt::format("{}{}", i ? ", " : "", UnitCoordinate<D>(p[i]));
  return s + ")";
}

// "v1v2v3" for the face of type k.
template <int D>
std::string FaceName(int type) {
  std::string s;
  for (int i = 0; i <= D; ++i) {
    if (i != OmittedVertex<D>(type)) s += fmt::format("v{}", i + 1);
  }
  return s;
}

template <int D>
void Inspect(SimplexCode<D> code) {
  const SimplexVertices<D> v = Vertices(code);
  const auto edge = SplitEdge(code);
  Point<D> mid{};
  for (int i = 0; i < D; ++i) mid[i] = (v[edge[0]][i] + v[edge[1]][i]) / 2;
  fmt::print("{}: level {}, {} under root {}\n", code.ToString(), code.level(),
             ShapeName(code), code.top());
  for (int i = 0; i <= D; ++i) fmt::print("  v{}  {}\n", i + 1, FormatPoint<D>(v[i]));
  fmt::print("  splits v{}v{} ({}) at {}\n", edge[0] + 1, edge[1] + 1,
             EdgeAlignment<D>(v[edge[0]], v[edge[1]]), FormatPoint<D>(mid));
  fmt::print("  parent    {}\n", code.level() > 0 ? code.parent().ToString() : "none (a root)");
  if (code.level() < SimplexCode<D>::kMaxLevel) {
    fmt::print("  children  {}  {}\n", code.child(0).ToString(), code.child(1).ToString());
  }
  for (int k = 1; k <= D + 1; ++k) {
    const SimplexCode<D> n = Neighbor(code, k);
    fmt::print("  neighbor type {} (face {})  {}\n", k, FaceName<D>(k),
               n.is_none() ? "none: the face is on the domain's boundary" : n.ToString());
  }
  const auto cluster = Cluster(code);
  fmt::print("  cluster: {} simplices share the split edge:", cluster.size());
  for (const SimplexCode<D> m : cluster) fmt::print(" {}", m.ToString());
  fmt::print("\n");
}

template <int D>
void InspectAll(const std::vector<std::string>& texts) {
  for (const std::string& text : texts) {
    const Result<SimplexCode<D>> code = SimplexCode<D>::Parse(text);
    if (!code.ok()) throw CommandError(std::string(code.status().message()));
    Inspect(*code);
  }
}

}  // namespace

namespace {

// Adds --hierarchy to `cmd`; `required` or defaulting to ht. The returned
// name is one of kHierarchyNames' keys (CLI11 matches case-insensitively and
// stores the key).
std::shared_ptr<std::string> AddHierarchyOption(CLI::App* cmd, bool required) {
  auto name = std::make_shared<std::string>("ht");
  std::vector<std::string> names;
  for (const auto& [n, h] : kHierarchyNames) names.push_back(n);
  auto* opt = cmd->add_option("--hierarchy", *name, kHierarchyHelp)
                  ->transform(CLI::IsMember(names, CLI::ignore_case));
  if (required) {
    opt->required();
  } else {
    opt->capture_default_str();
  }
  return name;
}

// Calls fn.template operator()<D>() with the dimension of `h`.
template <class Fn>
void WithDimension(const std::string& name, Fn&& fn) {
  switch (kHierarchyNames.at(name)) {
    case Hierarchy::kHT: fn.template operator()<3>(); break;
    case Hierarchy::kHP: fn.template operator()<4>(); break;
  }
}

}  // namespace

void RegisterCodesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "codes",
      "Describe location codes read from stdin, one per line, as JSON lines:\n"
      "{\"code\",\"level\",\"vertices\" (unit-cube coordinates, v1 first),\n"
      "\"neighbors\" (face types 1..D+1, null on the domain boundary),\n"
      "\"parent\",\"children\" (null at the deepest level a key holds: HT 55,\n"
      "HP 53),\"cluster\"}. A line that is not a code gets {\"code\",\"error\"}\n"
      "and the exit status is 1.");
  auto hierarchy = AddHierarchyOption(cmd, /*required=*/true);
  cmd->callback([hierarchy] { WithDimension(*hierarchy, []<int D>() { RunCodes<D>(); }); });
}

void RegisterInspectCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "inspect",
      "Explain location codes for people: shape, vertices, split edge,\n"
      "parent and children, face neighbors and cluster.\n"
      "Examples: simplexdb inspect --hierarchy ht 2:10011\n"
      "          simplexdb inspect --hierarchy hp 7:10100110101100100011");
  auto hierarchy = AddHierarchyOption(cmd, /*required=*/false);
  auto codes = std::make_shared<std::vector<std::string>>();
  cmd->add_option("codes", *codes, "location codes T:bits")->required();
  cmd->callback([hierarchy, codes] {
    WithDimension(*hierarchy, [&]<int D>() { InspectAll<D>(*codes); });
  });
}

}  // namespace simplexdb::tools
