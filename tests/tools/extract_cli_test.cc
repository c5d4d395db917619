// simplexdb extract and conformity, end to end: the contract's forms, the
// files read back by VTK itself, and what a user sees for wrong input.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"
#include "tests/util/python_vtk.h"

namespace simplexdb {
namespace {

using testing::ReadWholeFile;
using testing::RunCli;
using testing::TempDir;

nlohmann::json Json(const testing::CommandResult& r) { return nlohmann::json::parse(r.out); }

size_t Lines(const std::string& text) {
  size_t n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

std::string PythonWithVtk() { return testing::FindPythonWithVtk("vtkmodules.vtkIOXML"); }

// Reads `vtu` with VTK (tests/query/vtk_read_vtu.py).
// With `arrays`, also every array's values (vtk_read_vtu.py --arrays).
nlohmann::json ReadWithVtk(const std::string& python, const std::string& vtu, bool arrays = false) {
  FILE* p = popen((python + " " SIMPLEXDB_QUERY_TEST_DIR "/vtk_read_vtu.py " + vtu + (arrays ? " --arrays" : ""))
                      .c_str(),
                  "r");
  if (p == nullptr) throw std::runtime_error("cannot run " + python);
  std::string out;
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  EXPECT_EQ(pclose(p), 0) << out;
  return nlohmann::json::parse(out);
}

class ExtractCli : public ::testing::Test {
 protected:
  void SetUp() override {
    nrrd_ = dir_.path() + "/p.nrrd";
    store_ = dir_.path() + "/p.sdb";
    ASSERT_EQ(RunCli("generate --field perlin --dims 33,33,33 --type uint8 --seed 3 -o " + nrrd_).exit_code, 0);
    ASSERT_EQ(RunCli("import " + nrrd_ + " -o " + store_ + " -q").exit_code, 0);
  }
  TempDir dir_;
  std::string nrrd_, store_;
};

TEST_F(ExtractCli, CodesJsonAndConformity) {
  const std::string codes = dir_.path() + "/m.codes";
  auto r = RunCli("extract " + store_ + " --error 5% --format codes -o " + codes);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("extract " + store_ + " --error 5% --format json --check");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = Json(r);
  for (const char* key : {"simplices", "splits", "cluster_computations", "seconds", "blocks_read"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["conforming"], true);
  EXPECT_EQ(Lines(ReadWholeFile(codes)), j["simplices"].get<size_t>());
  r = RunCli("conformity " + codes);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["conforming"], true);

  // Every algorithm agrees on the count but saturation, which is not smaller.
  for (const char* a : {"priority", "incremental"}) {
    r = RunCli("extract " + store_ + " --error 5% --algorithm " + a);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(Json(r)["simplices"], j["simplices"]) << a;
  }
  r = RunCli("extract " + store_ + " --error 5% --algorithm saturated");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_GE(Json(r)["simplices"].get<uint64_t>(), j["simplices"].get<uint64_t>());

  // Incremental from the 5% mesh to 2%: the same as depth-first at 2% here.
  r = RunCli("extract " + store_ + " --error 2% --algorithm incremental --from " + codes + " --check");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto inc = Json(r);
  r = RunCli("extract " + store_ + " --error 2%");
  EXPECT_GE(inc["simplices"].get<uint64_t>(), Json(r)["simplices"].get<uint64_t>());
  EXPECT_EQ(inc["conforming"], true);

  // A mesh with a simplex missing, or with a hanging vertex, is refused.
  std::string text = ReadWholeFile(codes);
  const std::string broken = dir_.path() + "/broken.codes";
  std::ofstream(broken) << text.substr(text.find('\n') + 1);
  r = RunCli("conformity " + broken);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.err.find("not a conforming mesh"), std::string::npos) << r.err;
  // Split one leaf alone: its children leave a hanging vertex.
  const std::string first = text.substr(0, text.find('\n'));
  std::ofstream(broken) << first + "0\n" + first + "1\n" + text.substr(text.find('\n') + 1);
  r = RunCli("conformity " + broken);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_NE(r.err.find("hanging vertex"), std::string::npos) << r.err;
}

TEST_F(ExtractCli, VtuReadByVtk) {
  const std::string python = PythonWithVtk();
  if (python.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  const std::string vtu = dir_.path() + "/m.vtu";
  for (const std::string criteria : {"--error 0", "--error 3%", "--error 1% --box 4,4,4,20,12,30",
                                     "--error 0.5% --iso 128"}) {
    SCOPED_TRACE(criteria);
    auto r = RunCli("extract " + store_ + " " + criteria + " --format vtu -o " + vtu);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto stats = Json(r);
    r = RunCli("info " + store_ + " --json");
    const auto info = Json(r);
    const auto vtk = ReadWithVtk(python, vtu);
    EXPECT_EQ(vtk["cells"], stats["simplices"]);
    EXPECT_EQ(vtk["cell_types"], nlohmann::json::array({10}));  // VTK_TETRA
    // The tetrahedra tile the 2^5 cube exactly, every one positively
    // oriented as VTK counts it.
    EXPECT_NEAR(vtk["volume"].get<double>(), 32.0 * 32 * 32, 1e-6);
    EXPECT_NEAR(vtk["signed_volume"].get<double>(), 32.0 * 32 * 32, 1e-6);
    EXPECT_EQ(vtk["negative_cells"], 0);
    // Points: shared, within the grid; field within the store's range.
    EXPECT_LE(vtk["points"].get<uint64_t>(), 33u * 33 * 33);
    EXPECT_GE(vtk["point_arrays"]["field"][0].get<double>(), info["field_min"].get<double>());
    EXPECT_LE(vtk["point_arrays"]["field"][1].get<double>(), info["field_max"].get<double>());
    for (const char* a : {"error", "level", "code"}) EXPECT_TRUE(vtk["cell_arrays"].contains(a)) << a;
    EXPECT_LE(vtk["cell_arrays"]["level"][1].get<double>(), 15);
    // zlib-compressed, 32-bit indices for a mesh this small.
    EXPECT_EQ(vtk["file"]["compressor"], "vtkZLibDataCompressor");
    EXPECT_EQ(vtk["file"]["header_type"], "UInt64");
    EXPECT_EQ(vtk["file"]["arrays"]["connectivity"]["type"], "Int32");
    EXPECT_EQ(vtk["file"]["arrays"]["offsets"]["type"], "Int32");
    EXPECT_EQ(vtk["file"]["arrays"]["code"]["type"], "UInt64");
  }
}

// Without --format the output's extension names it; a --format the
// extension contradicts is refused before anything is written.
TEST_F(ExtractCli, FormatFromTheOutputsExtension) {
  const std::string vtu = dir_.path() + "/x.vtu", codes = dir_.path() + "/x.txt";
  auto r = RunCli("extract " + store_ + " --error 3% -o " + vtu);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadWholeFile(vtu).rfind("<?xml", 0), 0u);
  r = RunCli("extract " + store_ + " --error 3% -o " + codes);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = ReadWholeFile(codes);
  EXPECT_EQ(static_cast<uint64_t>(std::count(text.begin(), text.end(), '\n')), Json(r)["simplices"].get<uint64_t>());
  const std::string other = dir_.path() + "/y.vtu";
  r = RunCli("extract " + store_ + " --error 3% --format json -o " + other);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--format json contradicts"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(other));
  // An extension that names no format (issue 40: mesh.vtk held JSON), or
  // none: refused, naming what would be written, unless --format says.
  for (const char* name : {"/mesh.vtk", "/stats.out", "/mesh"}) {
    SCOPED_TRACE(name);
    const std::string out = dir_.path() + name;
    r = RunCli("extract " + store_ + " --error 3% -o " + out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find("name the file .vtu (the mesh, for ParaView)"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
  r = RunCli("extract " + store_ + " --error 3% --format json -o " + dir_.path() + "/stats.out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(ReadWholeFile(dir_.path() + "/stats.out")).contains("simplices"));
  // The extension in any case.
  r = RunCli("extract " + store_ + " --error 3% -o " + dir_.path() + "/upper.VTU");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadWholeFile(dir_.path() + "/upper.VTU").rfind("<?xml", 0), 0u);
}

// Criteria that meet nothing of the grid (33^3 here, field 0..255 at most)
// are errors naming the value and the valid range.
TEST_F(ExtractCli, CriteriaThatMeetNothingAreErrors) {
  const auto info = Json(RunCli("info " + store_ + " --json"));
  struct Case {
    std::string args, expected;
  };
  const double above = info["field_max"].get<double>() + 1;
  for (const Case& c : {Case{"--box 40,0,0,50,32,32", "x from 40 to 50 misses the grid, whose x runs from 0 to 32"},
                        Case{"--box 0,0,-9,32,32,-1", "z from -9 to -1 misses the grid"},
                        Case{"--iso " + std::to_string(above), "outside the field's range"}}) {
    SCOPED_TRACE(c.args);
    const auto r = RunCli("extract " + store_ + " --error 1% " + c.args);
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
  }
  // A box that overlaps the grid in part is fine.
  EXPECT_EQ(RunCli("extract " + store_ + " --error 1% --box 30,30,30,60,60,60").exit_code, 0);
}

// The statistics report the decoded blocks the cache holds, within the
// budget given (the scale runs of bench/experiments.py read them).
TEST_F(ExtractCli, ReportsTheCacheWithinItsBudget) {
  auto r = RunCli("extract " + store_ + " --error 0 --cache-mb 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = Json(r);
  EXPECT_GT(j["cache_bytes"].get<uint64_t>(), 0u);
  EXPECT_LE(j["cache_bytes"].get<uint64_t>(), uint64_t{1} << 20);
  EXPECT_GE(j["peak_memory_bytes"].get<uint64_t>(), j["cache_bytes"].get<uint64_t>());
  EXPECT_GE(j["anonymous_memory_bytes"].get<uint64_t>(), j["cache_bytes"].get<uint64_t>());
  EXPECT_LE(j["anonymous_memory_bytes"].get<uint64_t>(), j["peak_memory_bytes"].get<uint64_t>());

  // With a cache that holds the store, the full-resolution mesh decodes
  // each block and brick once, bricks among them (the field around the
  // finest boxes), and computes finest errors for at most every grid point.
  r = RunCli("extract " + store_ + " --error 0 --cache-mb 256");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto all = Json(r);
  const auto info = Json(RunCli("info " + store_ + " --json"));
  EXPECT_EQ(all["blocks_decoded"], all["distinct_blocks"]);
  EXPECT_GT(all["bricks_decoded"].get<uint64_t>(), 0u);
  EXPECT_LT(all["bricks_decoded"].get<uint64_t>(), all["blocks_decoded"].get<uint64_t>());
  EXPECT_LE(all["bricks_decoded"].get<uint64_t>(), info["bricks"].get<uint64_t>());
  EXPECT_GT(all["finest_vertices_computed"].get<uint64_t>(), 0u);
  EXPECT_LE(all["finest_vertices_computed"].get<uint64_t>(), info["grid_points"].get<uint64_t>());
}

// A grid that is not 2^k + 1 on a side, with a physical spacing (the
// NRRD's) and origin (given on import): the mesh VTK reads covers the real
// grid in physical units, no more.
TEST(ExtractCliPadded, VtuCoversTheRealGridInPhysicalUnits) {
  const std::string python = PythonWithVtk();
  if (python.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  const TempDir dir;
  const std::string nrrd = dir.path() + "/v.nrrd", store = dir.path() + "/v.sdb";
  const testing::TestVolume v = testing::TestVolume::Random(3, {20, 13, 27, 1}, VoxelType::kU8, 8);
  {
    std::ofstream out(nrrd, std::ios::binary);
    out << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 20 13 27\nspacings: 0.5 2 1.5\nencoding: raw\n\n";
    for (double x : v.values) out.put(static_cast<char>(static_cast<uint8_t>(x)));
  }
  ASSERT_EQ(RunCli("import " + nrrd + " --origin -5,10,2.5 -o " + store + " -q").exit_code, 0);
  for (const std::string criteria : {"--error 0", "--error 10%", "--error 100%",
                                     "--error 1% --units physical --box 2,2,2,4,20,30"}) {
    SCOPED_TRACE(criteria);
    const std::string vtu = dir.path() + "/m.vtu";
    auto r = RunCli("extract " + store + " " + criteria + " -o " + vtu);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto vtk = ReadWithVtk(python, vtu);
    EXPECT_EQ(vtk["bounds"], nlohmann::json::parse("[-5, 4.5, 10, 34, 2.5, 41.5]"));
    EXPECT_NEAR(vtk["volume"].get<double>(), 9.5 * 24 * 39, 1e-6);
    EXPECT_NEAR(vtk["signed_volume"].get<double>(), 9.5 * 24 * 39, 1e-6);
    EXPECT_EQ(vtk["negative_cells"], 0);
  }
  // A box in physical units outside the grid names both.
  auto r = RunCli("extract " + store + " --error 1% --units physical --box 0,0,45,9,24,50");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("z from 45 to 50 misses the grid, whose z runs from 2.5 to 41.5 (physical units)"),
            std::string::npos)
      << r.err;
  // The same box in grid units meets the grid.
  EXPECT_EQ(RunCli("extract " + store + " --error 1% --box 0,0,20,9,12,26").exit_code, 0);
  r = RunCli("extract " + store + " --error 1% --units metres");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--units metres: expected grid or physical"), std::string::npos) << r.err;
}

// Flipped axes (negative NRRD space directions, as NIfTI's qfac -1 and
// radiological x): the grid lies where the directions say, every cell
// positive, every grid point's field the voxel VTK finds there; an export
// of it is written forwards, the same voxels at the same places.
TEST(ExtractCliPadded, FlippedAxesLandWhereTheDirectionsSay) {
  const std::string python = PythonWithVtk();
  if (python.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  const TempDir dir;
  const std::array<uint32_t, 3> n = {20, 13, 27};
  const testing::TestVolume v = testing::TestVolume::Random(3, {n[0], n[1], n[2], 1}, VoxelType::kU8, 9);
  const auto voxel = [&](int64_t i, int64_t j, int64_t k) { return v.values[i + n[0] * (j + n[1] * k)]; };
  // x flipped (one flip: cells are mirrored and must be turned back), then
  // x and z (two). The grid's box is the same both times.
  const struct {
    const char* directions;
    const char* origin;
    std::array<double, 3> spacing;
  } cases[] = {{"(-0.5,0,0) (0,2,0) (0,0,1.5)", "(4.5,10,2.5)", {-0.5, 2, 1.5}},
               {"(-0.5,0,0) (0,2,0) (0,0,-1.5)", "(4.5,10,41.5)", {-0.5, 2, -1.5}}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.directions);
    const std::string nrrd = dir.path() + "/f.nrrd", store = dir.path() + "/f.sdb";
    {
      std::ofstream out(nrrd, std::ios::binary | std::ios::trunc);
      out << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 20 13 27\nspace dimension: 3\nspace directions: "
          << c.directions << "\nspace origin: " << c.origin << "\nencoding: raw\n\n";
      for (double x : v.values) out.put(static_cast<char>(static_cast<uint8_t>(x)));
    }
    ASSERT_EQ(RunCli("import " + nrrd + " -o " + store + " -q --force").exit_code, 0);
    auto r = RunCli("info " + store + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["spacing"].get<std::vector<double>>(),
              std::vector<double>(c.spacing.begin(), c.spacing.end()));
    for (const std::string criteria : {"--error 0", "--error 10%", "--error 1% --units physical --box 2,2,2,4,20,30"}) {
      SCOPED_TRACE(criteria);
      const std::string vtu = dir.path() + "/m.vtu";
      r = RunCli("extract " + store + " " + criteria + " -o " + vtu);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      const auto vtk = ReadWithVtk(python, vtu, criteria == "--error 0");
      EXPECT_EQ(vtk["bounds"], nlohmann::json::parse("[-5, 4.5, 10, 34, 2.5, 41.5]"));
      EXPECT_NEAR(vtk["signed_volume"].get<double>(), 9.5 * 24 * 39, 1e-6);
      EXPECT_EQ(vtk["negative_cells"], 0);
      if (criteria != "--error 0") continue;
      // At error 0 the field at every mesh point on the grid is the voxel's:
      // the point's grid index is (position - origin) / spacing.
      const std::vector<uint64_t> bits = vtk["values"]["points"], field = vtk["values"]["field"];
      const std::array<double, 3> origin = {4.5, 10, c.spacing[2] < 0 ? 41.5 : 2.5};
      int on_grid = 0;
      for (size_t p = 0; p < field.size(); ++p) {
        std::array<double, 3> g{};
        bool grid_point = true;
        for (int a = 0; a < 3; ++a) {
          g[a] = (std::bit_cast<double>(bits[3 * p + a]) - origin[a]) / c.spacing[a];
          grid_point = grid_point && std::fabs(g[a] - std::round(g[a])) < 1e-9;
        }
        if (!grid_point) continue;
        ++on_grid;
        ASSERT_EQ(std::bit_cast<double>(field[p]),
                  voxel(std::llround(g[0]), std::llround(g[1]), std::llround(g[2])))
            << "point " << p << " at grid (" << g[0] << ", " << g[1] << ", " << g[2] << ")";
      }
      // Nearly all: a diamond whose centre the coarser cells interpolate
      // exactly has error 0 and is not split even at error 0.
      EXPECT_GT(on_grid, 20 * 13 * 27 * 99 / 100);
    }
    // The sparse store keeps the flips too.
    const std::string sparse = dir.path() + "/f" + std::to_string(c.spacing[2] < 0) + ".lmdb";
    ASSERT_EQ(RunCli("import " + nrrd + " --sparse -o " + sparse + " -q").exit_code, 0);
    r = RunCli("info " + sparse + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["spacing"].get<std::vector<double>>(),
              std::vector<double>(c.spacing.begin(), c.spacing.end()));
    r = RunCli("extract " + sparse + " --error 5% -o " + dir.path() + "/s.vtu");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto vtk = ReadWithVtk(python, dir.path() + "/s.vtu");
    EXPECT_EQ(vtk["bounds"], nlohmann::json::parse("[-5, 4.5, 10, 34, 2.5, 41.5]"));
    EXPECT_EQ(vtk["negative_cells"], 0);
    // The export reads back with positive spacing and its voxels where the
    // store has them: x (and z) reversed.
    const std::string exported = dir.path() + "/e.nrrd";
    r = RunCli("export " + store + " -o " + exported + " --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const Result<VolumeInfo> e = OpenVolume(exported);
    ASSERT_TRUE(e.ok()) << e.status().ToString();
    EXPECT_EQ(e->spacing, (std::array<double, 4>{0.5, 2, 1.5, 1}));
    EXPECT_EQ(e->origin, (std::array<double, 4>{-5, 10, 2.5, 0}));
    std::vector<double> back(v.values.size());
    auto reader = VolumeReader::Open(*e);
    ASSERT_TRUE(reader.ok()) << reader.status().ToString();
    ASSERT_TRUE((*reader)->Read(0, back.size(), back.data()).ok());
    for (int64_t k = 0; k < n[2]; ++k) {
      for (int64_t j = 0; j < n[1]; ++j) {
        for (int64_t i = 0; i < n[0]; ++i) {
          const int64_t kk = c.spacing[2] < 0 ? n[2] - 1 - k : k;
          ASSERT_EQ(back[i + n[0] * (j + n[1] * k)], voxel(n[0] - 1 - i, j, kk)) << i << " " << j << " " << k;
        }
      }
    }
  }
}

TEST(ExtractCliHp, TimeSlicesReadByVtk) {
  const std::string python = PythonWithVtk();
  if (python.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  const TempDir dir;
  const std::string nrrd = dir.path() + "/p4.nrrd", store = dir.path() + "/p4.sdb";
  ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9,9 --type uint8 --seed 4 -o " + nrrd).exit_code, 0);
  ASSERT_EQ(RunCli("import " + nrrd + " -o " + store + " -q").exit_code, 0);
  auto r = RunCli("extract " + store + " --error 5% --time 3.5 --format vtu -o " + dir.path() + "/s.vtu");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto vtk = ReadWithVtk(python, dir.path() + "/s.vtu");
  EXPECT_EQ(vtk["cell_types"], nlohmann::json::array({10}));
  EXPECT_NEAR(vtk["volume"].get<double>(), 8.0 * 8 * 8, 1e-9);  // the slice fills the 2^3 cube
  EXPECT_NEAR(vtk["signed_volume"].get<double>(), 8.0 * 8 * 8, 1e-9);
  EXPECT_EQ(vtk["negative_cells"], 0);
  EXPECT_EQ(vtk["file"]["compressor"], "vtkZLibDataCompressor");
  // The statistics count the slice VTK reads; at error 0 on noise (no linear
  // region) a grid time is cut from the full-resolution mesh: 6 tetrahedra
  // per cube of the 8^3 grid, the count the seed's Fig. 63 gives as 100%.
  r = RunCli("extract " + store + " --error 5% --time 3.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["slice_tetrahedra"], vtk["cells"]);
  EXPECT_FALSE(Json(r).contains("full_resolution_slice_tetrahedra"));  // not a grid time
  r = RunCli("extract " + store + " --error 0 --time 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["slice_tetrahedra"], 6 * 8 * 8 * 8);
  EXPECT_EQ(Json(r)["full_resolution_slice_tetrahedra"], 6 * 8 * 8 * 8);
  EXPECT_GT(Json(r)["peak_memory_bytes"].get<uint64_t>(), 0u);
  r = RunCli("extract " + store + " --error 5% --format pvd --slices 0,2.5,8 -o " + dir.path() + "/series.pvd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pvd = ReadWholeFile(dir.path() + "/series.pvd");
  for (int i = 0; i < 3; ++i) {
    const std::string file = "series_" + std::to_string(i) + ".vtu";
    EXPECT_NE(pvd.find("file=\"" + file + "\""), std::string::npos) << pvd;
    vtk = ReadWithVtk(python, dir.path() + "/" + file);
    EXPECT_NEAR(vtk["volume"].get<double>(), 512.0, 1e-9) << file;
    EXPECT_NEAR(vtk["signed_volume"].get<double>(), 512.0, 1e-9) << file;
    EXPECT_EQ(vtk["negative_cells"], 0) << file;
    EXPECT_EQ(vtk["file"]["compressor"], "vtkZLibDataCompressor") << file;  // the same writer as .vtu
  }
  // Placed physically: points and the collection's times, and --slices in
  // physical units with --units physical.
  const std::string placed = dir.path() + "/placed.sdb";
  ASSERT_EQ(RunCli("import " + nrrd + " --spacing 1,1,1,2 --origin 0,0,-4,10 -o " + placed + " -q").exit_code, 0);
  r = RunCli("extract " + placed + " --error 5% --units physical --slices 10,15 -o " + dir.path() + "/placed.pvd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string placed_pvd = ReadWholeFile(dir.path() + "/placed.pvd");
  EXPECT_NE(placed_pvd.find("timestep=\"10\" part=\"0\" file=\"placed_0.vtu\""), std::string::npos) << placed_pvd;
  EXPECT_NE(placed_pvd.find("timestep=\"15\" part=\"0\" file=\"placed_1.vtu\""), std::string::npos) << placed_pvd;
  vtk = ReadWithVtk(python, dir.path() + "/placed_1.vtu");
  EXPECT_EQ(vtk["bounds"], nlohmann::json::parse("[0, 8, 0, 8, -4, 4]"));
  r = RunCli("extract " + store + " --error 5% --format vtu -o " + dir.path() + "/x.vtu");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--time"), std::string::npos) << r.err;
  // A time outside the store's (0 to 8 here) meets nothing: an error.
  for (const char* t : {"8.5", "-1"}) {
    r = RunCli("extract " + store + " --error 5% --time " + t);
    EXPECT_EQ(r.exit_code, 2) << t;
    EXPECT_NE(r.err.find("outside the store's times, 0 to 8"), std::string::npos) << r.err;
  }
}

TEST_F(ExtractCli, ClearErrors) {
  auto r = RunCli("extract " + store_ + " --error -1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--error"), std::string::npos) << r.err;
  r = RunCli("extract " + store_ + " --error 1 --box 1,2,3");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--box"), std::string::npos) << r.err;
  r = RunCli("extract " + store_ + " --error 1 --algorithm fastest");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("depth-first"), std::string::npos) << r.err;
  r = RunCli("extract " + store_ + " --error 1 --time 3");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("HP"), std::string::npos) << r.err;
  r = RunCli("extract " + dir_.path() + "/missing.sdb --error 1");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("missing.sdb"), std::string::npos) << r.err;
  r = RunCli("extract " + store_ + " --error 1 --format vtu");
  EXPECT_EQ(r.exit_code, 2);
}

}  // namespace
}  // namespace simplexdb
