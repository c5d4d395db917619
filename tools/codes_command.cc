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
#include "hierarchy/tri_code.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_neighbors.h"
#include "ops/code_json.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

// Keys in the order the contract lists them.
using json = nlohmann::ordered_json;

enum class Hierarchy { kHT, kHP, kTriIcosahedron, kTriOctahedron, kTriTetrahedron };

const std::map<std::string, Hierarchy> kHierarchyNames = {
    {"ht", Hierarchy::kHT},
    {"hp", Hierarchy::kHP},
    {"tri-icosahedron", Hierarchy::kTriIcosahedron},
    {"tri-octahedron", Hierarchy::kTriOctahedron},
    {"tri-tetrahedron", Hierarchy::kTriTetrahedron}};
constexpr const char* kHierarchyHelp =
    "ht: Hierarchy of Tetrahedra (3D); hp: Hierarchy of Pentatopes (4D);\n"
    "tri-icosahedron, tri-octahedron, tri-tetrahedron: triangle quadtrees on\n"
    "the sphere over that solid's faces (codes F:bits, two bits per level)";

std::string_view Trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// Far longer than any code ("T:" and at most 56 bits): a longer line is
// reported by its length, not quoted whole.
constexpr size_t kMaxCodeLineBytes = 256;

template <class Code>
void RunCodes() {
  std::string line;
  size_t line_number = 0;
  size_t bad = 0;
  while (std::getline(std::cin, line)) {
    ++line_number;
    const std::string_view text = Trim(line);
    if (text.empty()) continue;
    const Result<Code> code = text.size() <= kMaxCodeLineBytes
                                  ? Code::Parse(text)
                                  : Result<Code>(Status::InvalidArgument(fmt::format(
                                        "a line of {} bytes is too long to be a location code",
                                        text.size())));
    if (!code.ok()) {
      // Keep the output aligned with the input: one object per code line.
      // Any bytes may come in; the JSON stays valid UTF-8 (SetJsonBytes).
      ++bad;
      const std::string why = std::string(code.status().message());
      json j;
      SetJsonBytes(j, "code", text.substr(0, Utf8PrefixLength(text, kMaxCodeLineBytes)));
      j["error"] = ToValidUtf8(why);
      std::cout << j.dump() << '\n';
      std::cerr << fmt::format("simplexdb codes: line {}: {}\n", line_number, why);
      continue;
    }
    std::cout << CodeJson(*code) << '\n';
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

template <Polyhedron P>
void Inspect(TriCode<P> code) {
  static const char* kSolids[] = {"tetrahedron", "octahedron", "icosahedron"};
  static const char* kDirections[] = {"left", "right", "vertical"};
  const bool up = FaceIsTipUp<P>(code.face()) != code.flipped();
  fmt::print("{}: level {}, tip-{} triangle on face {} of the {}\n", code.ToString(),
             code.level(), up ? "up" : "down", code.face(), kSolids[static_cast<int>(P)]);
  const TriPoints poly = PolyhedronVertices(code);
  static const char* kCorners[] = {"apex ", "left ", "right"};
  for (int i = 0; i < 3; ++i) {
    const LatLng ll = PointToLatLng(poly[i]);
    fmt::print("  {}  ({}, {}, {})  lat {:.9f} lng {:.9f}\n", kCorners[i], poly[i][0],
               poly[i][1], poly[i][2], ll.lat_degrees, ll.lng_degrees);
  }
  fmt::print("  parent    {}\n", code.level() > 0 ? code.parent().ToString() : "none (a base face)");
  if (code.level() < TriCode<P>::kMaxLevel) {
    fmt::print("  children  {}  {}  {}  {}\n", code.child(0).ToString(), code.child(1).ToString(),
               code.child(2).ToString(), code.child(3).ToString());
  }
  for (int d = 0; d < kTriDirections; ++d) {
    const auto dir = static_cast<TriDirection>(d);
    const TriCode<P> n = TriNeighbor(code, dir);
    fmt::print("  neighbor {:<8}  {}{}\n", kDirections[d], n.ToString(),
               n.face() != code.face() ? fmt::format(" (across to face {})", n.face()) : "");
  }
}

template <class Code>
void InspectAll(const std::vector<std::string>& texts) {
  for (const std::string& text : texts) {
    const Result<Code> code = Code::Parse(text);
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

// Calls fn.template operator()<Code>() with the location code type of the
// hierarchy named `name`.
template <class Fn>
void WithCodeType(const std::string& name, Fn&& fn) {
  switch (kHierarchyNames.at(name)) {
    case Hierarchy::kHT: fn.template operator()<TetCode>(); break;
    case Hierarchy::kHP: fn.template operator()<PentaCode>(); break;
    case Hierarchy::kTriIcosahedron: fn.template operator()<IcosaCode>(); break;
    case Hierarchy::kTriOctahedron: fn.template operator()<OctaCode>(); break;
    case Hierarchy::kTriTetrahedron: fn.template operator()<TetraCode>(); break;
  }
}

// `simplexdb codes --help`.
constexpr const char* kCodesHelp = R"(Describe location codes read from stdin, one per line, as JSON lines:
{"code","level","vertices" (unit-cube coordinates, v1 first),
"neighbors" (face types 1..D+1, null on the domain boundary),
"parent","children" (null at the deepest level a key holds: HT 55,
HP 53),"cluster"}. Triangle quadtrees (tri-*): vertices apex, left,
right on the solid inscribed in the unit sphere; neighbors left, right,
vertical; four children (null at level 27 on the icosahedron, 28 on the
others); an empty cluster. A line that is not a code gets
{"code","error"} (and "code_hex", its bytes in hex, when the
line is not UTF-8; a line over 256 bytes is cut there) and the exit
status is 1.
Example: echo 2:10011 | simplexdb codes --hierarchy ht)";

// `simplexdb inspect --help`.
constexpr const char* kInspectHelp = R"(Explain location codes for people: shape, vertices, split edge,
parent and children, face neighbors and cluster.
Examples: simplexdb inspect --hierarchy ht 2:10011
          simplexdb inspect --hierarchy hp 7:10100110101100100011
          simplexdb inspect --hierarchy tri-icosahedron 2:010001010001)";

}  // namespace

void RegisterCodesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("codes", kCodesHelp);
  auto hierarchy = AddHierarchyOption(cmd, /*required=*/true);
  cmd->callback(
      [hierarchy] { WithCodeType(*hierarchy, []<class Code>() { RunCodes<Code>(); }); });
}

void RegisterInspectCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("inspect", kInspectHelp);
  auto hierarchy = AddHierarchyOption(cmd, /*required=*/false);
  auto codes = std::make_shared<std::vector<std::string>>();
  cmd->add_option("codes", *codes, "location codes T:bits (F:bits for tri-*)")->required();
  cmd->callback([hierarchy, codes] {
    WithCodeType(*hierarchy, [&]<class Code>() { InspectAll<Code>(*codes); });
  });
}

}  // namespace simplexdb::tools
