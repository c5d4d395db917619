// The dense store's writer and its build paths: blocks and bricks written
// in runs in any order, which virtual blocks hold which vertices, the
// build in several windows against one (also with missing values and a
// mask), and coarse reads from one lattice's bricks against the field.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/dense/dense_writer.h"
#include "storage/volume/volume.h"
#include "tests/storage/dense/dense_test_util.h"
#include "tests/util/long_run.h"

namespace simplexdb {
namespace {

using testing::BuildStore;
using testing::ExpectFields;
using testing::ForEachInternalCode;
using testing::TempDir;
using testing::TestVolume;

// A store written in runs (blocks and bricks in two or three runs each,
// later ones first) answers as the store whose errors it copies; Finish
// refuses a store with a brick missing, and a writer dropped unfinished
// leaves nothing.
TEST(DenseWriter, WriterTakesBlocksAndBricksInRunsInAnyOrder) {
  TempDir dir;
  // The reference stores every octave's errors (a volume with missing
  // values), so the writer asks for every block and no brick maxima.
  TestVolume v = TestVolume::Random(3, {21, 17, 40, 1}, VoxelType::kF32, 41);
  testing::PunchHoles(v, 41, 3, 0);
  DenseBuildOptions o;
  o.quantization = Quantization::kF32;  // copied exactly (errors_are_bounds)
  o.block_bits = 6;                      // many blocks
  const auto reference = BuildStore(v, dir, "v", o);
  ASSERT_NE(reference, nullptr);
  ASSERT_TRUE(reference->header().finest_stored());
  const DenseStore& b = *reference;
  const DenseHeader& ref = b.header();
  const DenseFill fill = [&](int, uint64_t first, size_t count, double* errors) -> Status {
    const std::optional<uint64_t> stored = b.StoredIndex(first >> ref.block_bits);
    if (!stored) return Status::OK();  // zeros
    SDB_ASSIGN_OR_RETURN(const DenseStore::BlockHandle h, b.Block(*stored));
    for (size_t i = 0; i < count; ++i) {
      errors[i] = b.quantizer().Decode(b.StoredErrorAt(h.data, static_cast<uint32_t>(i)));
    }
    return Status::OK();
  };
  DenseWriteOptions w;
  w.errors_are_bounds = true;
  w.threads = 2;
  {
    auto unfinished = DenseStoreWriter::Create(dir / "unfinished.sdb", ref, w);
    ASSERT_TRUE(unfinished.ok()) << unfinished.status().message();
    std::vector<uint64_t> all((*unfinished)->candidate_blocks().size());
    for (uint64_t i = 0; i < all.size(); ++i) all[i] = i;
    ASSERT_TRUE((*unfinished)->WriteBlocks(all, fill).ok());
    const Result<DenseHeader> refused = (*unfinished)->Finish();
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.status().message().find("brick 0 was not written"), std::string_view::npos)
        << refused.status().message();
  }
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename().string().find("unfinished"), std::string::npos) << entry.path();
  }

  auto writer = DenseStoreWriter::Create(dir / "runs.sdb", ref, w);
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  DenseStoreWriter& out = **writer;
  const uint64_t blocks = out.candidate_blocks().size(), bricks = out.header().bricks;
  ASSERT_GT(blocks, 8u);
  // Odd candidates from the last down, then the even ones.
  std::vector<uint64_t> odd, even;
  for (uint64_t i = blocks; i-- > 0;) (i % 2 ? odd : even).push_back(i);
  ASSERT_TRUE(out.WriteBlocks(odd, fill).ok());
  const std::vector<uint64_t> again = {odd[0]}, past = {blocks};
  EXPECT_FALSE(out.WriteBlocks(again, fill).ok());  // written before
  EXPECT_FALSE(out.WriteBlocks(past, fill).ok());   // past the candidates
  ASSERT_TRUE(out.WriteBlocks(even, fill).ok());
  // Bricks in three runs, the last third first; the field as a whole, and
  // as planes from 16 on for the bricks of the first two thirds that start
  // there (the coarse lattices' bricks come first).
  std::vector<std::vector<uint64_t>> thirds(3);
  for (uint64_t i = 0; i < bricks; ++i) thirds[std::min<uint64_t>(2, 3 * i / bricks)].push_back(i);
  const HeldField<double> whole{v.values.data(), {1, 21, 21 * 17, 21 * 17 * 40}, 0, 0};
  HeldField<double> from16 = whole;
  from16.data += 16 * 21 * 17;
  from16.first_plane = 16;
  std::vector<uint64_t> later;
  for (const uint64_t brick : thirds[2]) {
    (out.grid().Place(brick).first[2] >= 16 ? later : thirds[1]).push_back(brick);
  }
  ASSERT_FALSE(later.empty());
  ASSERT_TRUE(out.WriteBricks(later, from16, nullptr).ok());
  ASSERT_FALSE(out.WriteBricks(later, from16, nullptr).ok());  // written before
  ASSERT_TRUE(out.WriteBricks(thirds[1], whole, nullptr).ok());
  ASSERT_TRUE(out.WriteBricks(thirds[0], whole, nullptr).ok());
  ASSERT_TRUE(out.Finish().ok());

  auto runs = DenseStore::Open(dir / "runs.sdb");
  ASSERT_TRUE(runs.ok()) << runs.status().message();
  ASSERT_TRUE((*runs)->Verify().ok());
  EXPECT_EQ((*runs)->stored_blocks(), b.stored_blocks());
  DenseStore::Reader<3> got(**runs), want(b);
  ForEachInternalCode<3>(ref.leaf_level(), [&](SimplexCode<3> c) {
    ASSERT_EQ(*got.ErrorBound(c), *want.ErrorBound(c)) << c.ToString();
  });
  ExpectFields<3>(**runs, v);
}

// Every vertex a virtual block holds is in its span (found by decoding
// each position, not by the span's arithmetic), at the span's scale; the
// candidates are the blocks whose span may reach the real grid, and every
// block holding a real point is one. HT and HP, block_bits a multiple of D
// or not.
template <int D>
void ExpectBlockSpans(const std::array<uint32_t, 4>& dims, int block_bits) {
  SCOPED_TRACE("block_bits " + std::to_string(block_bits));
  TempDir dir;
  DenseHeader params;
  params.dimension = static_cast<uint8_t>(D);
  params.domain_bits = static_cast<uint8_t>(std::max(1, DomainBitsFor(D, dims)));
  params.block_bits = static_cast<uint8_t>(block_bits);
  params.brick_bits = static_cast<uint8_t>(DenseDefaultBrickBits(D));
  params.dims = dims;
  params.field_max = 1;
  auto writer = DenseStoreWriter::Create(dir / "s.sdb", params, DenseWriteOptions{});
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  const DenseHeader& h = (*writer)->header();
  const HzOrder<D> order(h.domain_bits);
  const std::set<uint64_t> candidates((*writer)->candidate_blocks().begin(),
                                      (*writer)->candidate_blocks().end());
  int spans = 0;
  for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
    const DenseStoreWriter::BlockSpan span = (*writer)->SpanOf(b);
    spans += span.scale >= 0;
    bool real = false;
    for (uint64_t p = b << h.block_bits; p < std::min(order.size(), (b + 1) << h.block_bits); ++p) {
      std::array<int64_t, D> g{};
      if (!order.Decode(p, g)) continue;
      bool inside = true;
      for (int a = 0; a < D; ++a) {
        ASSERT_GE(g[a], span.lo[a]) << "block " << b << " position " << p;
        ASSERT_LE(g[a], span.hi[a]) << "block " << b << " position " << p;
        inside = inside && g[a] < int64_t{dims[a]};
      }
      real = real || inside;
      if (span.scale >= 0) {
        ASSERT_EQ(h.domain_bits - 1 - order.Level(g) / D, span.scale) << "block " << b;
      }
    }
    if (real) {
      ASSERT_EQ(candidates.count(b), 1u) << "block " << b << " holds a real point";
    }
  }
  EXPECT_GT(spans, 0);
}

TEST(DenseWriter, BlockSpansHoldTheirVertices) {
  ExpectBlockSpans<3>({21, 17, 13, 1}, 6);
  ExpectBlockSpans<3>({33, 9, 20, 1}, 7);
  ExpectBlockSpans<4>({9, 5, 7, 6}, 6);
  ExpectBlockSpans<4>({9, 9, 5, 9}, 7);
}

// Stores with the same blocks and bricks, byte for byte (each entry's size,
// coding and checksum), wherever each lies in its file, and the same header
// but for where things are.
void ExpectSameContent(const DenseStore& a, const DenseStore& b) {
  const DenseHeader &x = a.header(), &y = b.header();
  EXPECT_EQ(x.flags, y.flags);
  EXPECT_EQ(x.field_min, y.field_min);
  EXPECT_EQ(x.field_max, y.field_max);
  EXPECT_EQ(x.error_max, y.error_max);
  EXPECT_EQ(x.quantum, y.quantum);
  ASSERT_EQ(x.virtual_blocks, y.virtual_blocks);
  ASSERT_EQ(x.stored_blocks, y.stored_blocks);
  ASSERT_EQ(x.bricks, y.bricks);
  for (uint64_t v = 0; v < x.virtual_blocks; ++v) {
    ASSERT_EQ(a.StoredIndex(v), b.StoredIndex(v)) << "block " << v;
  }
  const auto same = [](const DenseIndexEntry& e, const DenseIndexEntry& f) {
    return e.stored_size == f.stored_size && e.encoding == f.encoding && e.checksum == f.checksum &&
           e.field_min == f.field_min && e.field_max == f.field_max && e.error_max == f.error_max;
  };
  for (uint64_t i = 0; i < x.stored_blocks; ++i) {
    ASSERT_TRUE(same(a.entry(i), b.entry(i))) << "stored block " << i;
  }
  for (uint64_t i = 0; i < x.bricks; ++i) {
    ASSERT_TRUE(same(a.brick_entry(i), b.brick_entry(i))) << "brick " << i;
  }
}

// Several windows of planes make the store that one window over the whole
// field makes, block for block and brick for brick (so every node's bound,
// every field value and the grid bricks' finest maxima), HT and HP,
// integer and float voxels, non-cubic, several slabs and chunks; with
// missing values (holes of NaN) and with a mask, whose stores keep every
// octave. (The one-window store's answers are checked against brute force
// in dense_store_test.cc.)
template <int D>
void ExpectWindowsMatchTheWholeField(const TestVolume& v, const std::string& name, int block_bits,
                                     const TestVolume* mask = nullptr) {
  SCOPED_TRACE(name);
  TempDir dir;
  const std::string nrrd = dir / (name + ".nrrd");
  ASSERT_TRUE(v.WriteNrrd(nrrd).ok());
  DenseBuildOptions options;
  options.block_bits = block_bits;
  if (mask != nullptr) {
    ASSERT_TRUE(mask->WriteNrrd(dir / "mask.nrrd").ok());
    options.mask = *OpenVolume(dir / "mask.nrrd");
  }
  const auto whole = BuildDenseStore(*OpenVolume(nrrd), dir / "whole.sdb", options);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  ASSERT_EQ(whole->windows, 1);
  options.stream = true;
  const auto windows = BuildDenseStore(*OpenVolume(nrrd), dir / "windows.sdb", options);
  ASSERT_TRUE(windows.ok()) << windows.status().message();
  ASSERT_GT(windows->windows, 1);
  auto a = DenseStore::Open(dir / "whole.sdb");
  auto b = DenseStore::Open(dir / "windows.sdb");
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_TRUE((*b)->Verify().ok());
  ExpectSameContent(**a, **b);
}

// HT slabs are 64 planes with a halo of 32, HP slabs 32 with a halo of 8
// (dense_windowed_build.cc). At domain side 128 (HT) and 32 (HP) the default
// cases cross slabs: 2 and 3 HT slabs (the second with local chunks of 128
// and 256 planes spanning them), 2 HP slabs (the second holds the last
// plane only). The long run (`ctest -L long`) adds a side of 256 (HT, a
// third scanned scale) and of 64 (HP, a second slab of 8 real planes).
TEST(DenseWriter, WindowsMatchTheWholeField) {
  ExpectWindowsMatchTheWholeField<3>(TestVolume::Random(3, {65, 40, 77, 1}, VoxelType::kU8, 51), "ht_u8", 6);
  ExpectWindowsMatchTheWholeField<3>(TestVolume::Random(3, {70, 66, 129, 1}, VoxelType::kF32, 52), "ht_f32", 9);
  ExpectWindowsMatchTheWholeField<4>(TestVolume::Random(4, {20, 17, 9, 33}, VoxelType::kI16, 53), "hp_i16", 6);
  ExpectWindowsMatchTheWholeField<4>(TestVolume::Random(4, {9, 12, 10, 33}, VoxelType::kF32, 54), "hp_long_t", 6);
  if (testing::LongRun()) {
    ExpectWindowsMatchTheWholeField<3>(TestVolume::Random(3, {70, 66, 150, 1}, VoxelType::kF32, 52),
                                       "ht_f32_256", 9);
    ExpectWindowsMatchTheWholeField<4>(TestVolume::Random(4, {9, 12, 10, 40}, VoxelType::kF32, 54),
                                       "hp_long_t_64", 6);
  }
}

// The window is the widest the memory bound allows: the whole field when
// it fits, more and narrower windows as the bound shrinks (planned beside
// what the process holds besides, 28 MiB at two workers), down to the
// narrowest (the one `stream` takes), then a refusal that names both needs
// and leaves nothing behind. The plan is the build's, and every window
// gives the same store.
TEST(DenseWriter, TheWindowNarrowsWithTheMemoryBound) {
  TempDir dir;
  // Long along the last axis, and float64, so that a window fits beside
  // the process where the whole field does not.
  const TestVolume v = TestVolume::Random(3, {64, 64, 1024, 1}, VoxelType::kF64, 58);
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  const VolumeInfo in = *OpenVolume(dir / "v.nrrd");
  DenseBuildOptions options;
  options.threads = 2;
  options.stream = true;
  const auto narrowest = PlanDenseBuild(in, dir / "refused.sdb", options);
  ASSERT_TRUE(narrowest.ok()) << narrowest.status().message();
  ASSERT_GT(narrowest->windows, 2);
  options.stream = false;
  const auto whole = BuildDenseStore(in, dir / "whole.sdb", options);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  ASSERT_EQ(whole->windows, 1);
  // The plans from 64 MiB down in steps of 256 KiB; a build at the first
  // width between the whole field and the narrowest (the content of
  // several windows against one: WindowsMatchTheWholeField).
  std::set<int> widths;
  int last = 1;
  bool refused = false, built = false;
  for (size_t bytes = size_t{64} << 20; bytes > (size_t{256} << 10); bytes -= size_t{256} << 10) {
    SCOPED_TRACE(bytes);
    options.memory_bytes = bytes;
    const auto plan = PlanDenseBuild(in, dir / "refused.sdb", options);
    if (!plan.ok()) {
      refused = true;
      EXPECT_TRUE(plan.status().IsResourceExhausted()) << plan.status().ToString();
      EXPECT_EQ(last, narrowest->windows) << "refused before the narrowest window";
      const auto build = BuildDenseStore(in, dir / "refused.sdb", options);
      ASSERT_FALSE(build.ok());
      EXPECT_EQ(build.status().message(), plan.status().message());
      EXPECT_NE(build.status().message().find("the narrowest"), std::string_view::npos) << build.status().message();
      EXPECT_NE(build.status().message().find("(--memory-mb)"), std::string_view::npos) << build.status().message();
      EXPECT_FALSE(std::filesystem::exists(dir / "refused.sdb"));
      break;
    }
    EXPECT_LE(plan->bytes, bytes);
    EXPECT_GE(plan->windows, last) << "a smaller bound took a wider window";
    last = plan->windows;
    widths.insert(last);
    if (built || last == 1 || last == narrowest->windows) continue;
    built = true;
    const auto build = BuildDenseStore(in, dir / "between.sdb", options);
    ASSERT_TRUE(build.ok()) << build.status().message();
    EXPECT_EQ(build->windows, plan->windows);
    EXPECT_EQ(build->window_planes, plan->window_planes);
    ExpectSameContent(**DenseStore::Open(dir / "whole.sdb"), **DenseStore::Open(dir / "between.sdb"));
  }
  EXPECT_TRUE(refused) << "no bound down to 256 KiB refused the build";
  EXPECT_TRUE(built) << "no bound took a width between the whole field and the narrowest";
  EXPECT_GE(widths.size(), 4u) << "the window took fewer than four widths";
}

TEST(DenseWriter, WindowsMatchTheWholeFieldWithMissingValues) {
  TestVolume ht = TestVolume::Random(3, {70, 66, 129, 1}, VoxelType::kF32, 55);
  testing::PunchHoles(ht, 55, 12, 101);
  ExpectWindowsMatchTheWholeField<3>(ht, "ht_holes", 9);
  TestVolume hp = TestVolume::Random(4, {20, 17, 9, 33}, VoxelType::kF32, 56);
  testing::PunchHoles(hp, 56, 4, 37);
  ExpectWindowsMatchTheWholeField<4>(hp, "hp_holes", 6);
  const TestVolume u8 = TestVolume::Random(3, {65, 40, 77, 1}, VoxelType::kU8, 57);
  TestVolume mask = u8;
  for (double& x : mask.values) x = x < 30 ? 0 : 1;
  ExpectWindowsMatchTheWholeField<3>(u8, "ht_mask", 6, &mask);
}

// Coarse reads from one lattice's bricks against the reader's Field, point
// by point: every lattice, the whole grid and a box inside it.
template <int D>
void ExpectLatticeReads(const TestVolume& v, const std::string& name) {
  SCOPED_TRACE(name);
  TempDir dir;
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  ASSERT_TRUE(BuildDenseStore(*OpenVolume(dir / "v.nrrd"), dir / "v.sdb", DenseBuildOptions{}).ok());
  const auto store = *DenseStore::Open(dir / "v.sdb");
  DenseStore::Reader<D> reader(*store);
  const DenseHeader& h = store->header();
  for (int s = 0; s <= h.domain_bits; ++s) {
    const int64_t step = int64_t{1} << s;
    std::array<int64_t, 4> lo{}, hi{}, inner_lo{}, inner_hi{};
    for (int a = 0; a < D; ++a) {
      hi[a] = int64_t{h.dims[a]} - 1;
      inner_lo[a] = (h.dims[a] / 3) / step * step;
      inner_hi[a] = std::max(inner_lo[a], int64_t{h.dims[a]} * 2 / 3);
    }
    for (const auto& [from, to] : {std::pair{lo, hi}, std::pair{inner_lo, inner_hi}}) {
      std::array<int64_t, 4> n{1, 1, 1, 1};
      uint64_t count = 1;
      for (int a = 0; a < D; ++a) {
        n[a] = (to[a] - from[a]) / step + 1;
        count *= static_cast<uint64_t>(n[a]);
      }
      std::vector<double> got(count);
      ASSERT_TRUE(ReadLattice(*store, s, from, to, got.data()).ok()) << "lattice " << s;
      for (uint64_t i = 0; i < count; ++i) {
        std::array<int64_t, D> p{};
        uint64_t rest = i;
        for (int a = 0; a < D; ++a) {
          p[a] = from[a] + static_cast<int64_t>(rest % static_cast<uint64_t>(n[a])) * step;
          rest /= static_cast<uint64_t>(n[a]);
        }
        ASSERT_EQ(got[i], *reader.Field(p)) << "lattice " << s << " " << ::testing::PrintToString(p);
      }
    }
  }
  // A box not starting on the lattice, or past the grid, is refused.
  std::array<int64_t, 4> lo{}, hi{};
  for (int a = 0; a < D; ++a) hi[a] = int64_t{h.dims[a]} - 1;
  lo[0] = 1;
  std::vector<double> out(size_t{1} << 20);
  EXPECT_TRUE(ReadLattice(*store, 1, lo, hi, out.data()).IsInvalidArgument());
  lo[0] = 0;
  hi[0] = h.dims[0];
  EXPECT_TRUE(ReadLattice(*store, 0, lo, hi, out.data()).IsInvalidArgument());
  EXPECT_TRUE(ReadLattice(*store, h.domain_bits + 1, lo, lo, out.data()).IsInvalidArgument());
}

TEST(DenseWriter, LatticeReadsEqualTheFieldPointByPoint) {
  ExpectLatticeReads<3>(TestVolume::Random(3, {37, 21, 18, 1}, VoxelType::kU8, 41), "ht");
  ExpectLatticeReads<3>(TestVolume::Random(3, {9, 17, 5, 1}, VoxelType::kF32, 42), "ht_float");
  ExpectLatticeReads<4>(TestVolume::Random(4, {11, 9, 5, 7}, VoxelType::kI16, 43), "hp");
}

}  // namespace
}  // namespace simplexdb
