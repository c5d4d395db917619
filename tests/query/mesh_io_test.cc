// WriteVtu's files read back by VTK itself (tests/query/vtk_read_vtu.py):
// every array of a synthetic mesh, bit for bit, across several zlib blocks
// and a partial last one, an exact number of blocks, and the Int64
// connectivity a mesh too large for Int32 gets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "query/mesh_io.h"
#include "query/mesh_io_internal.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/python_vtk.h"

namespace simplexdb {
namespace {

using testing::TempDir;

// What VTK reads from `vtu`, with every array (vtk_read_vtu.py --arrays).
nlohmann::json ReadWithVtk(const std::string& python, const std::string& vtu) {
  FILE* p = popen((python + " " SIMPLEXDB_QUERY_TEST_DIR "/vtk_read_vtu.py " + vtu + " --arrays").c_str(), "r");
  if (p == nullptr) throw std::runtime_error("cannot run " + python);
  std::string out;
  char buf[1 << 16];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  EXPECT_EQ(pclose(p), 0) << out.substr(0, 2000);
  return nlohmann::json::parse(out);
}

// The file up to its appended data: the XML VTK parses.
std::string XmlOf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  return text.substr(0, text.find("<AppendedData"));
}

// The integers of the bits of each double, as vtk_read_vtu.py prints them.
std::vector<uint64_t> Bits(const std::vector<double>& v) {
  std::vector<uint64_t> out(v.size());
  std::memcpy(out.data(), v.data(), 8 * v.size());
  return out;
}

// A mesh whose arrays hold random values (fixed seed) and a few special
// doubles; the cells are random tuples of point indices (VTK's reader does
// not look at the geometry).
TetMeshData SyntheticMesh(uint64_t points, uint64_t cells, uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> real(-1e3, 1e3);
  TetMeshData m;
  for (uint64_t i = 0; i < 3 * points; ++i) m.points.push_back(real(rng));
  for (uint64_t i = 0; i < points; ++i) m.field.push_back(real(rng));
  for (uint64_t i = 0; i < 4 * cells; ++i) m.connectivity.push_back(static_cast<int64_t>(rng() % points));
  for (uint64_t i = 0; i < cells; ++i) {
    m.error.push_back(std::ldexp(real(rng), -static_cast<int>(rng() % 60)));
    m.level.push_back(static_cast<uint8_t>(rng()));
    m.code.push_back(rng());  // the full 64 bits, above 2^63 too
  }
  m.field[0] = -0.0;
  m.field[1] = std::numeric_limits<double>::denorm_min();
  m.error[0] = std::numeric_limits<double>::max();
  m.error[1] = 0.0;
  m.code[0] = ~uint64_t{0};
  return m;
}

// VTK reads back exactly the arrays written, with the types asked for.
void ExpectReadBackExactly(const nlohmann::json& vtk, const TetMeshData& m, const std::string& index_type) {
  EXPECT_EQ(vtk["points"], m.field.size());
  EXPECT_EQ(vtk["cells"], m.cells());
  const nlohmann::json& file = vtk["file"];
  EXPECT_EQ(file["compressor"], "vtkZLibDataCompressor");
  EXPECT_EQ(file["header_type"], "UInt64");
  EXPECT_EQ(file["encoding"], "raw");
  for (const auto& [name, type] : std::vector<std::pair<std::string, std::string>>{
           {"field", "Float64"},
           {"error", "Float64"},
           {"level", "UInt8"},
           {"code", "UInt64"},
           {"Points", "Float64"},
           {"connectivity", index_type},
           {"offsets", index_type},
           {"types", "UInt8"}}) {
    EXPECT_EQ(file["arrays"][name]["type"], type) << name;
  }
  const nlohmann::json& v = vtk["values"];
  EXPECT_TRUE(v["points"].get<std::vector<uint64_t>>() == Bits(m.points));
  EXPECT_TRUE(v["field"].get<std::vector<uint64_t>>() == Bits(m.field));
  EXPECT_TRUE(v["error"].get<std::vector<uint64_t>>() == Bits(m.error));
  EXPECT_TRUE(v["level"].get<std::vector<uint8_t>>() == m.level);
  EXPECT_TRUE(v["code"].get<std::vector<uint64_t>>() == m.code);
  EXPECT_TRUE(v["connectivity"].get<std::vector<int64_t>>() == m.connectivity);
  std::vector<int64_t> offsets(m.cells() + 1);
  for (uint64_t i = 0; i < offsets.size(); ++i) offsets[i] = static_cast<int64_t>(4 * i);
  EXPECT_TRUE(v["offsets"].get<std::vector<int64_t>>() == offsets);
  EXPECT_TRUE(v["types"].get<std::vector<uint8_t>>() == std::vector<uint8_t>(m.cells(), 10));  // VTK_TETRA
}

class VtuReadByVtk : public ::testing::Test {
 protected:
  void SetUp() override {
    python_ = testing::FindPythonWithVtk("vtkmodules.vtkIOXML");
    if (python_.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  }
  std::string python_;
  TempDir dir_;
};

// With the options WriteVtu uses: each cell array and the points span
// several blocks and end in a partial one.
TEST_F(VtuReadByVtk, SeveralBlocksRoundTripExactly) {
  const uint64_t block = internal::DefaultVtuOptions().block_bytes;
  const uint64_t cells = 2 * block / 8 + 1001, points = block / 8 + 777;  // 8-byte cell arrays: 3 blocks
  const TetMeshData m = SyntheticMesh(points, cells, 7);
  const std::string vtu = dir_ / "m.vtu";
  ASSERT_TRUE(WriteVtu(m, vtu).ok());
  const nlohmann::json vtk = ReadWithVtk(python_, vtu);
  ExpectReadBackExactly(vtk, m, "Int32");
  const nlohmann::json& arrays = vtk["file"]["arrays"];
  struct Expected {
    const char* name;
    uint64_t bytes;
  };
  for (const Expected& e : {Expected{"field", 8 * points}, Expected{"error", 8 * cells}, Expected{"level", cells},
                            Expected{"code", 8 * cells}, Expected{"Points", 24 * points},
                            Expected{"connectivity", 16 * cells}, Expected{"offsets", 4 * cells},
                            Expected{"types", cells}}) {
    SCOPED_TRACE(e.name);
    EXPECT_EQ(arrays[e.name]["block_size"], block);
    EXPECT_EQ(arrays[e.name]["blocks"], (e.bytes + block - 1) / block);
    EXPECT_EQ(arrays[e.name]["last_block_size"], e.bytes % block);
  }
  EXPECT_EQ(arrays["error"]["blocks"], 3);
  EXPECT_GE(arrays["connectivity"]["blocks"], 5);
  EXPECT_GT(arrays["connectivity"]["last_block_size"], 0);
}

// Arrays that fill their last block exactly: the header's third word is 0
// (vtkXMLWriter's convention, which VTK's reader relies on). Small blocks
// and one thread per block, so many blocks are compressed at once.
TEST_F(VtuReadByVtk, WholeBlocksRoundTripExactly) {
  internal::VtuOptions options = internal::DefaultVtuOptions();
  options.block_bytes = 4096;
  options.threads = 3;
  const TetMeshData m = SyntheticMesh(1024, 4096, 11);  // every array a whole number of 4 KiB blocks
  const std::string vtu = dir_ / "whole.vtu";
  ASSERT_TRUE(internal::WriteVtu(m, vtu, options).ok());
  const nlohmann::json vtk = ReadWithVtk(python_, vtu);
  ExpectReadBackExactly(vtk, m, "Int32");
  for (const auto& [name, a] : vtk["file"]["arrays"].items()) {
    SCOPED_TRACE(name);
    EXPECT_EQ(a["block_size"], 4096);
    EXPECT_GE(a["blocks"], 1);
    EXPECT_EQ(a["last_block_size"], 0);
  }
  EXPECT_EQ(vtk["file"]["arrays"]["connectivity"]["blocks"], 16);
}

// A mesh past the Int32 limit (lowered here) gets Int64 connectivity and
// offsets, which VTK reads back the same.
TEST_F(VtuReadByVtk, Int64WhenIndicesPassTheLimit) {
  internal::VtuOptions options = internal::DefaultVtuOptions();
  options.int32_limit = 1000;
  options.block_bytes = 8192;
  const TetMeshData m = SyntheticMesh(1001, 3000, 13);
  const std::string vtu = dir_ / "int64.vtu";
  ASSERT_TRUE(internal::WriteVtu(m, vtu, options).ok());
  ExpectReadBackExactly(ReadWithVtk(python_, vtu), m, "Int64");
}

// The Int32 test at its edges: Int32 while the point count and 4 * cells
// are both within the limit.
TEST(VtuIndexType, Int32UpToTheLimit) {
  const TempDir dir;
  struct Case {
    uint64_t points, cells, limit;
    const char* type;
  };
  for (const Case& c : {Case{20, 5, 20, "Int32"}, Case{20, 5, 19, "Int64"}, Case{21, 5, 20, "Int64"},
                        Case{20, 6, 20, "Int64"}}) {
    SCOPED_TRACE(std::to_string(c.points) + " points, " + std::to_string(c.cells) + " cells, limit " +
                 std::to_string(c.limit));
    internal::VtuOptions options = internal::DefaultVtuOptions();
    options.int32_limit = c.limit;
    const std::string vtu = dir / "edge.vtu";
    ASSERT_TRUE(internal::WriteVtu(SyntheticMesh(c.points, c.cells, 5), vtu, options).ok());
    const std::string xml = XmlOf(vtu);
    for (const char* name : {"connectivity", "offsets"}) {
      EXPECT_NE(xml.find(std::string("type=\"") + c.type + "\" Name=\"" + name + "\""), std::string::npos)
          << name << "\n"
          << xml;
    }
  }
}

}  // namespace
}  // namespace simplexdb
