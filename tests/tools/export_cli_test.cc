// simplexdb export of an HP (4D) store: one 3D NRRD (or .vti) per time step
// and a .pvd, read back by VTK's own readers (tests/tools/
// vtk_read_nrrd_series.py) and compared with the input volume indexed by
// hand; --time T; the errors; a failed series leaves nothing.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "storage/volume/nrrd_writer.h"
#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"
#include "tests/util/python_vtk.h"

namespace simplexdb {
namespace {

using testing::RunCli;
using testing::TempDir;
namespace fs = std::filesystem;

// The input: 24 x 9 x 8 x 5 int16 (x >= 10: vtkNrrdReader takes an x axis
// of 9 or fewer points for vector components), anisotropic spacing.
constexpr std::array<uint32_t, 4> kDims = {24, 9, 8, 5};
constexpr std::array<double, 4> kSpacing = {0.5, 2, 1.5, 0.25};

double InputValue(int64_t x, int64_t y, int64_t z, int64_t t) {
  return static_cast<double>((x * 7 + y * 13 + z * 29 + t * 101) % 500 - 250);
}

// What VTK saw of one image (one line of vtk_read_nrrd_series.py).
struct VtkImage {
  std::string time;
  std::array<int, 3> dims{};
  std::array<double, 3> spacing{}, origin{};
  int components = 0;
  std::vector<double> values;
};

std::vector<VtkImage> ReadWithVtk(const std::string& python, const std::string& path) {
  const std::string cmd =
      python + " " SIMPLEXDB_TOOLS_TEST_DIR "/vtk_read_nrrd_series.py '" + path + "'";
  FILE* p = popen(cmd.c_str(), "r");
  EXPECT_NE(p, nullptr) << cmd;
  std::string out;
  char buf[4096];
  for (size_t n; p != nullptr && (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = p != nullptr ? pclose(p) : -1;
  EXPECT_EQ(status, 0) << cmd;
  std::vector<VtkImage> images;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream in(line);
    VtkImage im;
    size_t count = 0;
    in >> im.time;
    for (int& d : im.dims) in >> d;
    for (double& s : im.spacing) in >> s;
    for (double& o : im.origin) in >> o;
    in >> im.components >> count;
    for (size_t i = 0; i < count; ++i) {
      std::string text;
      in >> text;
      im.values.push_back(std::strtod(text.c_str(), nullptr));
    }
    images.push_back(std::move(im));
  }
  return images;
}

// The input's points lo + i * step (x, y, z) at time t, x fastest.
std::vector<double> Expected(std::array<int64_t, 3> lo, std::array<int64_t, 3> hi, int step,
                             int64_t t) {
  std::vector<double> v;
  for (int64_t z = lo[2]; z <= hi[2]; z += step) {
    for (int64_t y = lo[1]; y <= hi[1]; y += step) {
      for (int64_t x = lo[0]; x <= hi[0]; x += step) v.push_back(InputValue(x, y, z, t));
    }
  }
  return v;
}

class ExportCli : public ::testing::Test {
 protected:
  void SetUp() override {
    std::vector<double> values;
    for (uint32_t t = 0; t < kDims[3]; ++t) {
      for (uint32_t z = 0; z < kDims[2]; ++z) {
        for (uint32_t y = 0; y < kDims[1]; ++y) {
          for (uint32_t x = 0; x < kDims[0]; ++x) values.push_back(InputValue(x, y, z, t));
        }
      }
    }
    ASSERT_TRUE(WriteNrrd(dir_ / "in4.nrrd", 4, kDims, VoxelType::kI16, values, kSpacing).ok());
    auto r = RunCli("import " + (dir_ / "in4.nrrd") + " -o " + store4_ + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::vector<double> first(values.begin(), values.begin() + 24 * 9 * 8);
    ASSERT_TRUE(WriteNrrd(dir_ / "in3.nrrd", 3, {24, 9, 8, 1}, VoxelType::kI16, first,
                          {0.5, 2, 1.5, 1})
                    .ok());
    r = RunCli("import " + (dir_ / "in3.nrrd") + " -o " + store3_ + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    python_ = testing::FindPythonWithVtk("vtkmodules.vtkIOImage");
  }

  // The names in the output folder, sorted.
  std::vector<std::string> OutputNames() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(out_)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
  }

  TempDir dir_;
  std::string store4_ = dir_ / "v4.sdb", store3_ = dir_ / "v3.sdb";
  std::string out_ = [this] {
    fs::create_directory(dir_ / "out");
    return dir_ / "out";
  }();
  std::string python_;
};

TEST_F(ExportCli, HpToNrrdIsOneVtkReadable3DImagePerStepAndAPvd) {
  if (python_.empty()) GTEST_SKIP() << "no python3 that can import VTK (python3-vtk9)";
  const auto r = RunCli("export " + store4_ + " -o " + out_ + "/s.nrrd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(OutputNames(), (std::vector<std::string>{"s.pvd", "s_t0000.nrrd", "s_t0001.nrrd",
                                                     "s_t0002.nrrd", "s_t0003.nrrd",
                                                     "s_t0004.nrrd"}));
  const std::vector<VtkImage> images = ReadWithVtk(python_, out_ + "/s.pvd");
  ASSERT_EQ(images.size(), 5u);
  for (int64_t t = 0; t < 5; ++t) {
    SCOPED_TRACE("time step " + std::to_string(t));
    const VtkImage& im = images[static_cast<size_t>(t)];
    EXPECT_EQ(std::strtod(im.time.c_str(), nullptr), 0.25 * static_cast<double>(t));
    EXPECT_EQ(im.dims, (std::array<int, 3>{24, 9, 8}));
    EXPECT_EQ(im.components, 1);
    EXPECT_EQ(im.spacing, (std::array<double, 3>{0.5, 2, 1.5}));
    EXPECT_EQ(im.origin, (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(im.values, Expected({0, 0, 0}, {23, 8, 7}, 1, t));
  }
}

// -o OUT.pvd: the same steps as .vti, the format ParaView's .pvd reader
// opens, read back by vtkXMLImageDataReader.
TEST_F(ExportCli, HpToPvdIsAVtiPerStepForParaView) {
  if (python_.empty()) GTEST_SKIP() << "no python3 that can import VTK (python3-vtk9)";
  const auto r = RunCli("export " + store4_ + " --roi 2,1,1,1,23,8,7,4 --step 3 -o " + out_ +
                        "/p.pvd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(OutputNames(), (std::vector<std::string>{"p.pvd", "p_t0001.vti", "p_t0004.vti"}));
  const std::vector<VtkImage> images = ReadWithVtk(python_, out_ + "/p.pvd");
  ASSERT_EQ(images.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const int64_t t = 1 + 3 * static_cast<int64_t>(i);
    SCOPED_TRACE("time step " + std::to_string(t));
    EXPECT_EQ(std::strtod(images[i].time.c_str(), nullptr), 0.25 * static_cast<double>(t));
    // x 2..23 every 3rd: 8 points (VTK's XML reader makes no guess).
    EXPECT_EQ(images[i].dims, (std::array<int, 3>{8, 3, 3}));
    EXPECT_EQ(images[i].components, 1);
    EXPECT_EQ(images[i].spacing, (std::array<double, 3>{1.5, 6, 4.5}));
    EXPECT_EQ(images[i].origin, (std::array<double, 3>{1, 2, 1.5}));
    EXPECT_EQ(images[i].values, Expected({2, 1, 1}, {23, 8, 7}, 3, t));
  }
}

TEST_F(ExportCli, HpSeriesWithRoiAndStepPlacesEachStep) {
  if (python_.empty()) GTEST_SKIP() << "no python3 that can import VTK (python3-vtk9)";
  // t 0..4 every 2nd: steps 0, 2, 4; x 2..23 every 2nd: 11 points.
  const auto r =
      RunCli("export " + store4_ + " --roi 2,1,1,0,23,8,7,4 --step 2 -o " + out_ + "/b.nrrd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(OutputNames(),
            (std::vector<std::string>{"b.pvd", "b_t0000.nrrd", "b_t0002.nrrd", "b_t0004.nrrd"}));
  const std::vector<VtkImage> images = ReadWithVtk(python_, out_ + "/b.pvd");
  ASSERT_EQ(images.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const int64_t t = 2 * static_cast<int64_t>(i);
    SCOPED_TRACE("time step " + std::to_string(t));
    EXPECT_EQ(std::strtod(images[i].time.c_str(), nullptr), 0.25 * static_cast<double>(t));
    EXPECT_EQ(images[i].dims, (std::array<int, 3>{11, 4, 4}));
    EXPECT_EQ(images[i].spacing, (std::array<double, 3>{1, 4, 3}));
    // The box's first point: origin (0) + lo * spacing.
    EXPECT_EQ(images[i].origin, (std::array<double, 3>{1, 2, 1.5}));
    EXPECT_EQ(images[i].values, Expected({2, 1, 1}, {23, 8, 7}, 2, t));
  }
}

TEST_F(ExportCli, TimeGivesOneStepAs3D) {
  if (python_.empty()) GTEST_SKIP() << "no python3 that can import VTK (python3-vtk9)";
  auto r = RunCli("export " + store4_ + " --time 3 -o " + out_ + "/one.nrrd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(OutputNames(), std::vector<std::string>{"one.nrrd"});
  std::vector<VtkImage> images = ReadWithVtk(python_, out_ + "/one.nrrd");
  ASSERT_EQ(images.size(), 1u);
  EXPECT_EQ(images[0].dims, (std::array<int, 3>{24, 9, 8}));
  EXPECT_EQ(images[0].components, 1);
  EXPECT_EQ(images[0].spacing, (std::array<double, 3>{0.5, 2, 1.5}));
  EXPECT_EQ(images[0].values, Expected({0, 0, 0}, {23, 8, 7}, 1, 3));
  // --roi then has the three space axes.
  r = RunCli("export " + store4_ + " --time 4 --roi 2,1,1,23,8,7 --step 2 -o " + out_ +
             "/box.nrrd");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  images = ReadWithVtk(python_, out_ + "/box.nrrd");
  ASSERT_EQ(images.size(), 1u);
  EXPECT_EQ(images[0].dims, (std::array<int, 3>{11, 4, 4}));
  EXPECT_EQ(images[0].origin, (std::array<double, 3>{1, 2, 1.5}));
  EXPECT_EQ(images[0].values, Expected({2, 1, 1}, {23, 8, 7}, 2, 4));
}

TEST_F(ExportCli, TimeErrorsAreUsageErrorsNamingTheRange) {
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {store4_ + " --time 5", "--time 5: not a time step of " + store4_ +
                                  ": expected a whole number in 0..4"},
      {store4_ + " --time -1", "--time -1: not a time step"},
      {store4_ + " --time 1.5", "expected a whole number in 0..4"},
      {store3_ + " --time 0", store3_ + " is a 3D (HT) store; it has no time axis"},
      {store4_ + " --time 1 --roi 0,0,0,0,5,5,5,1", "--roi with --time is x0,y0,z0,x1,y1,z1"},
      {store4_ + " --time 1 -o " + out_ + "/x.pvd", "a .pvd is the time series of a 4D (HP) "
                                                    "store without --time"},
      {store3_ + " -o " + out_ + "/x.pvd", "a .pvd is the time series of a 4D (HP) store"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const std::string output = c.args.find(" -o ") == std::string::npos ? " -o " + out_ + "/x.nrrd" : "";
    const auto r = RunCli("export " + c.args + output);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_TRUE(OutputNames().empty());
  }
}

TEST_F(ExportCli, FailedSeriesLeavesNothing) {
  // The fourth step's name is a folder: refused after three steps are
  // written to their temporaries, which go away with the command.
  fs::create_directory(out_ + "/s_t0003.nrrd");
  const auto r = RunCli("export " + store4_ + " -o " + out_ + "/s.nrrd");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("s_t0003.nrrd"), std::string::npos) << r.err;
  EXPECT_EQ(OutputNames(), std::vector<std::string>{"s_t0003.nrrd"});
}

}  // namespace
}  // namespace simplexdb
