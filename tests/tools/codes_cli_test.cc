// `simplexdb codes` end to end: the JSON-lines contract of DESIGN.md, read
// back with a JSON parser and checked against geometry.
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "hierarchy/neighbors.h"
#include "hierarchy/level_scan.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_neighbors.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

using json = nlohmann::ordered_json;  // keeps the key order of the output
using ::testing::Test;
using testing::RunCli;

std::vector<json> ParseLines(const std::string& out) {
  std::vector<json> lines;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) lines.push_back(json::parse(line));
  return lines;
}

// Runs `codes` over `codes` and checks what the lines of every hierarchy
// share: one per code, in order, with the contract's keys in its order, the
// code, its level, its parent (null at level 0) and its `children` children
// (null at the deepest level a key holds); then `check(code, line)` checks
// the rest. The first failed ASSERT in `check` ends the run.
template <class Code, class Check>
void RunContract(const char* hierarchy, const std::vector<Code>& codes, int children,
                 Check check) {
  std::string input;
  for (const Code c : codes) input += c.ToString() + "\n";
  const auto r = RunCli(std::string("codes --hierarchy ") + hierarchy, input);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<json> lines = ParseLines(r.out);
  ASSERT_EQ(lines.size(), codes.size());
  for (size_t i = 0; i < codes.size(); ++i) {
    const Code c = codes[i];
    const json& j = lines[i];
    SCOPED_TRACE(c.ToString());
    std::vector<std::string> keys;
    for (auto it = j.begin(); it != j.end(); ++it) keys.push_back(it.key());
    ASSERT_EQ(keys, (std::vector<std::string>{"code", "level", "vertices", "neighbors",
                                              "parent", "children", "cluster"}));
    ASSERT_EQ(j["code"], c.ToString());
    ASSERT_EQ(j["level"], c.level());
    if (c.level() == 0) {
      ASSERT_TRUE(j["parent"].is_null());
    } else {
      ASSERT_EQ(j["parent"], c.parent().ToString());
    }
    if (c.level() == Code::kMaxLevel) {
      ASSERT_TRUE(j["children"].is_null()) << "no deeper level in a 64-bit key";
    } else {
      json expected = json::array();
      for (int k = 0; k < children; ++k) expected.push_back(c.child(k).ToString());
      ASSERT_EQ(j["children"], expected);
    }
    check(c, j);
    if (Test::HasFatalFailure()) return;
  }
}

// The codes a contract test checks: every code down to `full_level` below
// each of the `roots` roots (base faces for triangles), then 200 random ones
// from `seed` at levels 1 to the deepest a key holds. A level takes `bits`
// path bits: 1 for a simplex (two children), 2 for a triangle (four).
template <class Code>
std::vector<Code> ContractCodes(int roots, int bits, int full_level, uint64_t seed) {
  std::vector<Code> codes;
  for (int top = 0; top < roots; ++top) {
    for (int level = 0; level <= full_level; ++level) {
      for (uint64_t p = 0; p < (uint64_t{1} << (bits * level)); ++p) {
        codes.push_back(Code::FromPath(top, p, level));
      }
    }
  }
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 200; ++i) {
    const int level = 1 + static_cast<int>(rng() % Code::kMaxLevel);  // 1..max
    codes.push_back(Code::FromPath(static_cast<int>(rng() % roots), rng() >> (64 - bits * level),
                                   level));
  }
  return codes;
}

// The contract for one hierarchy: every code up to level 4 and random deep
// ones, each line checked against the library and geometry.
template <int D>
void CheckContract(const char* hierarchy, uint64_t seed) {
  using Code = SimplexCode<D>;
  const std::vector<Code> codes = ContractCodes<Code>(Code::kRoots, 1, 4, seed);
  RunContract(hierarchy, codes, 2, [](const Code c, const json& j) {
    // Unit-cube coordinates, exactly the lattice vertices scaled.
    const auto v = Vertices(c);
    ASSERT_EQ(j["vertices"].size(), size_t{D + 1});
    for (int k = 0; k <= D; ++k) {
      ASSERT_EQ(j["vertices"][k].size(), size_t{D});
      for (int a = 0; a < D; ++a) {
        const double x = j["vertices"][k][a].get<double>();
        ASSERT_GE(x, 0.0);
        ASSERT_LE(x, 1.0);
        ASSERT_EQ(x * kDomainSide<D>, v[k][a]);
      }
    }
    ASSERT_EQ(j["neighbors"].size(), size_t{D + 1});
    for (int k = 1; k <= D + 1; ++k) {
      const Code n = NeighborByLevelScan<D>(c, k);  // the reference algorithm
      if (n.is_none()) {
        ASSERT_TRUE(j["neighbors"][k - 1].is_null());
      } else {
        ASSERT_EQ(j["neighbors"][k - 1], n.ToString());
      }
    }
    std::set<std::string> cluster;
    for (const Code m : Cluster(c)) cluster.insert(m.ToString());
    ASSERT_EQ(j["cluster"].get<std::set<std::string>>(), cluster);
    ASSERT_EQ(j["cluster"][0], c.ToString());
  });
}

TEST(CodesCli, HtContract) { CheckContract<3>("ht", 4); }
TEST(CodesCli, HpContract) { CheckContract<4>("hp", 5); }

// The contract for a triangle quadtree: every code up to level 3, random
// deep ones and the deepest, each line checked against the library (the
// neighbors against the nearest-common-ancestor scan, the reference).
template <Polyhedron P>
void CheckTriContract(const char* hierarchy, uint64_t seed) {
  using Code = TriCode<P>;
  const std::vector<Code> codes = ContractCodes<Code>(Code::kFaces, 2, 3, seed);
  bool deepest = false;
  ASSERT_NO_FATAL_FAILURE(RunContract(hierarchy, codes, 4, [&](const Code c, const json& j) {
    deepest = deepest || c.level() == Code::kMaxLevel;
    // Apex, left, right on the solid, inscribed in the unit sphere; JSON
    // numbers round-trip doubles exactly.
    const TriPoints v = PolyhedronVertices(c);
    ASSERT_EQ(j["vertices"].size(), 3u);
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(j["vertices"][k].size(), 3u);
      for (int a = 0; a < 3; ++a) ASSERT_EQ(j["vertices"][k][a].get<double>(), v[k][a]);
    }
    ASSERT_EQ(j["neighbors"].size(), 3u);  // left, right, vertical; never null
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(j["neighbors"][d], TriNeighborScan(c, static_cast<TriDirection>(d)).ToString());
    }
    ASSERT_TRUE(j["cluster"].is_array());
    ASSERT_TRUE(j["cluster"].empty());
  }));
  EXPECT_TRUE(deepest || codes.size() < 1000);
}

TEST(CodesCli, TriIcosahedronContract) {
  CheckTriContract<Polyhedron::kIcosahedron>("tri-icosahedron", 6);
}
TEST(CodesCli, TriOctahedronContract) {
  CheckTriContract<Polyhedron::kOctahedron>("tri-octahedron", 7);
}
TEST(CodesCli, TriTetrahedronContract) {
  CheckTriContract<Polyhedron::kTetrahedron>("tri-tetrahedron", 8);
}

// The seed's EXCODE2 (2.3) crosses from face 2 to face 1; bad triangle
// codes are reported per line, aligned with the input.
TEST(CodesCli, TriSeedExampleAndBadLines) {
  const auto r = RunCli("codes --hierarchy tri-icosahedron",
                        "2:010001010001\n20:\n2:011\n" + std::string("19:") +
                            std::string(56, '0') + "\n7:\n");
  EXPECT_EQ(r.exit_code, 1);
  const std::vector<json> lines = ParseLines(r.out);
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(lines[0]["neighbors"][0], "1:110011110011");
  EXPECT_NE(lines[1]["error"].get<std::string>().find("out of range"), std::string::npos);
  EXPECT_NE(lines[2]["error"].get<std::string>().find("odd"), std::string::npos);
  EXPECT_NE(lines[3]["error"].get<std::string>().find("maximum level 27"), std::string::npos);
  EXPECT_EQ(lines[4]["neighbors"], (json{"11:", "12:", "2:"}));  // Fig. 7, row 7
  EXPECT_EQ(RunCli("codes --hierarchy TRI-Octahedron", "7:\n").exit_code, 0);
}

TEST(InspectCli, ExplainsATriangleCode) {
  const auto r = RunCli("inspect --hierarchy tri-icosahedron 2:010001010001");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("tip-up triangle on face 2 of the icosahedron"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("1:110011110011 (across to face 1)"), std::string::npos) << r.out;
  const auto tet = RunCli("inspect --hierarchy tri-tetrahedron 1:10");
  ASSERT_EQ(tet.exit_code, 0) << tet.err;
  EXPECT_NE(tet.out.find("tip-up triangle on face 1"), std::string::npos) << tet.out;
}

TEST(CodesCli, BadLinesKeepAlignmentAndFail) {
  const auto r = RunCli("codes --hierarchy ht", "0:1\nnonsense\n\n7:0\n1:01\n");
  EXPECT_EQ(r.exit_code, 1);
  const std::vector<json> lines = ParseLines(r.out);
  ASSERT_EQ(lines.size(), 4u);  // the blank line is skipped
  EXPECT_EQ(lines[0]["code"], "0:1");
  EXPECT_EQ(lines[1]["code"], "nonsense");
  EXPECT_TRUE(lines[1].contains("error"));
  EXPECT_NE(lines[2]["error"].get<std::string>().find("out of range"), std::string::npos);
  EXPECT_EQ(lines[3]["code"], "1:01");
  EXPECT_NE(r.err.find("line 2"), std::string::npos) << r.err;
}

TEST(CodesCli, UsageErrors) {
  EXPECT_EQ(RunCli("codes").exit_code, 2);
  EXPECT_EQ(RunCli("codes --hierarchy nope").exit_code, 2);
  EXPECT_EQ(RunCli("codes --hierarchy HT", "0:\n").exit_code, 0);  // case-insensitive
  EXPECT_EQ(RunCli("frobnicate").exit_code, 2);
  const auto help = RunCli("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("codes"), std::string::npos);
}

TEST(Cli, Version) {
  const auto r = RunCli("--version");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("simplexdb 0.", 0), 0u) << r.out;
  EXPECT_NE(r.out.find("sparse stores of header version"), std::string::npos) << r.out;
}

TEST(InspectCli, ExplainsACode) {
  const auto r = RunCli("inspect --hierarchy ht 2:10011");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("1/4 pyramid"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3:10011"), std::string::npos) << r.out;  // type-4 neighbor
  EXPECT_NE(r.out.find("8 simplices"), std::string::npos) << r.out;
  const auto hp = RunCli("inspect --hierarchy hp 9:010110");
  ASSERT_EQ(hp.exit_code, 0) << hp.err;
  EXPECT_NE(hp.out.find("s-pentatope"), std::string::npos) << hp.out;
  EXPECT_NE(hp.out.find("9:010010"), std::string::npos) << hp.out;  // 4.3's example
  EXPECT_NE(hp.out.find("16 simplices"), std::string::npos) << hp.out;
  const auto bad = RunCli("inspect 9:1");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("9:1"), std::string::npos);
}

}  // namespace
}  // namespace simplexdb
