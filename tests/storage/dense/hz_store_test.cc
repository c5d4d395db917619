// Store format 2 against independent truth: each node's error against the
// brute-force seed errors of its cluster (never below, within float
// rounding) and against the format-1 store it was made from, every field
// value against the volume, which blocks exist against a count over every
// HZ position, and damaged files (detected or harmless, never a crash).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <set>
#include <unordered_map>

#include "hierarchy/cluster.h"
#include "hierarchy/hz_order.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_lattice.h"
#include "storage/dense/hz_store.h"
#include "storage/dense/hz_writer.h"
#include "storage/volume/volume.h"
#include "tests/fuzz/hz_checksums.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/long_run.h"

namespace simplexdb {
namespace {

using testing::ReadFileBytes;
using testing::TempDir;
using testing::TestVolume;

struct Built {
  std::unique_ptr<DenseStore> f1;  // float32 errors: per-node bounds
  std::unique_ptr<HzStore> hz;
};

Built Build(const TestVolume& volume, const TempDir& dir, const std::string& name,
            HzBuildOptions options = {}) {
  const std::string nrrd = dir / (name + ".nrrd");
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  DenseBuildOptions f1;
  f1.quantization = Quantization::kF32;
  f1.levels_per_block = 6;
  EXPECT_TRUE(BuildDenseStore(*OpenVolume(nrrd), dir / (name + ".f1"), f1).ok());
  Built b;
  b.f1 = *DenseStore::Open(dir / (name + ".f1"));
  const auto report = ConvertToHz(*b.f1, dir / (name + ".sdb"), options);
  EXPECT_TRUE(report.ok()) << report.status().message();
  auto hz = HzStore::Open(dir / (name + ".sdb"));
  EXPECT_TRUE(hz.ok()) << hz.status().message();
  b.hz = *std::move(hz);
  return b;
}

template <int D>
void ForEachInternalCode(int leaf_level, const std::function<void(SimplexCode<D>)>& f) {
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < leaf_level; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) f(SimplexCode<D>::FromPath(top, p, l));
    }
  }
}

// Every node's error is the largest float32 bound of its cluster in the
// format-1 store, and never below the exact seed error of any member.
template <int D>
void ExpectDiamondErrors(const Built& b, const TestVolume& volume, bool brute_force) {
  const int k = b.hz->header().domain_bits;
  const int leaf = b.hz->header().leaf_level();
  HzStore::Reader<D> hz(*b.hz);
  DenseStore::Reader<D> f1(*b.f1);
  std::unordered_map<uint64_t, long double> brute;  // each node's exact error, once
  ForEachInternalCode<D>(leaf, [&](SimplexCode<D> c) {
    double cluster_max = 0;
    long double exact = 0;
    for (const auto m : Cluster(c)) {
      cluster_max = std::max(cluster_max, *f1.ErrorBound(m));
      if (!brute_force) continue;
      auto it = brute.find(m.key());
      if (it == brute.end()) it = brute.emplace(m.key(), testing::BruteForceError<D>(m, k, volume)).first;
      exact = std::max(exact, it->second);
    }
    const double e = *hz.ErrorBound(c);
    ASSERT_EQ(e, cluster_max) << c.ToString();
    if (brute_force) {
      ASSERT_GE(static_cast<long double>(e), exact) << c.ToString();
      ASSERT_LE(static_cast<long double>(e), exact * (1 + 1e-6L) + 1e-9L) << c.ToString();
    }
  });
}

// Every domain point's field: the volume's, clamped to the real grid.
template <int D>
void ExpectFields(const HzStore& store, const TestVolume& volume) {
  HzStore::Reader<D> reader(store);
  const int64_t side = int64_t{1} << store.header().domain_bits;
  std::array<int64_t, D> p{};
  while (true) {
    const Result<double> f = reader.Field(p);
    ASSERT_TRUE(f.ok()) << f.status().message();
    ASSERT_EQ(*f, volume.ClampedAt<D>(p));
    int c = 0;
    for (; c < D; ++c) {
      if (p[c] < side) {
        ++p[c];
        break;
      }
      p[c] = 0;
    }
    if (c == D) break;
  }
}

// The blocks stored are exactly block 0 and those holding a non-zero error,
// counted over every node; every brick of every lattice is stored.
template <int D>
void ExpectOnlyBlocksWithData(const HzStore& store) {
  const HzHeader& h = store.header();
  const HzOrder<D> order(h.domain_bits);
  HzStore::Reader<D> reader(store);
  std::set<uint64_t> needed = {0};
  ForEachInternalCode<D>(h.leaf_level(), [&](SimplexCode<D> c) {
    const uint64_t p = order.PositionOf(c);
    if (p < h.error_positions() && *reader.ErrorBound(c) > 0) needed.insert(p >> h.block_bits);
  });
  EXPECT_EQ(h.stored_blocks, needed.size());
  for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
    ASSERT_EQ(store.StoredIndex(b).has_value(), needed.count(b) == 1) << b;
  }
  uint64_t bricks = 0;
  for (int s = 0; s < store.grid().lattices(); ++s) bricks += store.grid().Count(s);
  EXPECT_EQ(h.bricks, bricks);
}

TEST(HzStore, Ht17DiamondErrorsAndFields) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kU8, 1);
  HzBuildOptions o;
  o.quantization = Quantization::kF32;
  const Built b = Build(v, dir, "v", o);
  ExpectDiamondErrors<3>(b, v, true);
  ExpectFields<3>(*b.hz, v);
  ASSERT_TRUE(b.hz->Verify().ok());
}

TEST(HzStore, Hp9DiamondErrorsAndFields) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 2);
  HzBuildOptions o;
  o.quantization = Quantization::kF32;
  o.block_bits = 6;
  const Built b = Build(v, dir, "v", o);
  ExpectDiamondErrors<4>(b, v, true);
  ExpectFields<4>(*b.hz, v);
  ASSERT_TRUE(b.hz->Verify().ok());
}

// Non-cubic grids: padding vertices whose diamonds reach real points keep
// their errors; blocks wholly in the padding are not stored.
TEST(HzStore, HtNonCubicKeepsOnlyBlocksWithData) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {11, 6, 17, 1}, VoxelType::kF32, 3);
  HzBuildOptions o;
  o.quantization = Quantization::kF32;
  o.block_bits = 6;
  const Built b = Build(v, dir, "v", o);
  ExpectDiamondErrors<3>(b, v, true);
  ExpectFields<3>(*b.hz, v);
  ExpectOnlyBlocksWithData<3>(*b.hz);
  EXPECT_LT(b.hz->header().stored_blocks, b.hz->header().virtual_blocks / 4);
}

TEST(HzStore, HpShortFourthAxisKeepsOnlyBlocksWithData) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(4, {7, 5, 6, 3}, VoxelType::kU8, 4);
  HzBuildOptions o;
  o.quantization = Quantization::kF32;
  o.block_bits = 6;
  const Built b = Build(v, dir, "v", o);
  ExpectDiamondErrors<4>(b, v, true);
  ExpectFields<4>(*b.hz, v);
  ExpectOnlyBlocksWithData<4>(*b.hz);
  EXPECT_LT(b.hz->header().stored_blocks, b.hz->header().virtual_blocks / 8);
}

// Quantized errors: never below the float32 diamond bound, within a quantum;
// raw and zstd blocks give the same answers.
TEST(HzStore, QuantizedErrorsRoundUpAndEncodingsAgree) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {17, 13, 9, 1}, VoxelType::kU16, 5);
  for (const Quantization q : {Quantization::kU16, Quantization::kU8}) {
    SCOPED_TRACE(static_cast<int>(q));
    HzBuildOptions zstd, raw;
    zstd.quantization = raw.quantization = q;
    raw.compression = Compression::kNone;
    const Built a = Build(v, dir, "z" + std::to_string(static_cast<int>(q)), zstd);
    const Built r = Build(v, dir, "r" + std::to_string(static_cast<int>(q)), raw);
    HzStore::Reader<3> ra(*a.hz), rr(*r.hz);
    DenseStore::Reader<3> f1(*a.f1);
    const double quantum = a.hz->header().quantum;
    ForEachInternalCode<3>(a.hz->header().leaf_level(), [&](TetCode c) {
      double bound = 0;
      for (const auto m : Cluster(c)) bound = std::max(bound, *f1.ErrorBound(m));
      const double e = *ra.ErrorBound(c);
      ASSERT_GE(e, bound) << c.ToString();
      ASSERT_LE(e, bound + quantum * (1 + 1e-9)) << c.ToString();
      ASSERT_EQ(e, *rr.ErrorBound(c)) << c.ToString();
    });
    ExpectFields<3>(*r.hz, v);
    ASSERT_TRUE(r.hz->Verify().ok());
  }
}

TEST(HzStore, EachFormatRefusesTheOtherByName) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 6);
  const Built b = Build(v, dir, "v");
  const auto old = HzStore::Open(dir / "v.f1");
  ASSERT_FALSE(old.ok());
  EXPECT_EQ(old.status().code(), Status::Code::kNotSupported);
  EXPECT_NE(old.status().message().find("format-1"), std::string::npos) << old.status().message();
  EXPECT_NE(old.status().message().find("import the volume again"), std::string::npos);
  const auto newer = DenseStore::Open(dir / "v.sdb");
  ASSERT_FALSE(newer.ok());
  EXPECT_EQ(newer.status().code(), Status::Code::kNotSupported);
}

void WriteBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// Every answer a store gives; nullopt when some lookup fails.
template <int D>
std::optional<std::vector<double>> AllAnswers(const HzStore& store);

// BuildHzStore from a volume file gives the store ConvertToHz makes of the
// volume's format-1 store, and leaves no scratch file behind.
TEST(HzStore, BuildFromAVolumeLeavesOnlyTheStore) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {12, 9, 14, 1}, VoxelType::kI16, 8);
  const Built b = Build(v, dir, "v");
  const auto built = BuildHzStore(*OpenVolume(dir / "v.nrrd"), dir / "w.sdb", HzBuildOptions{});
  ASSERT_TRUE(built.ok()) << built.status().message();
  auto w = HzStore::Open(dir / "w.sdb");
  ASSERT_TRUE(w.ok()) << w.status().message();
  EXPECT_EQ(AllAnswers<3>(**w), AllAnswers<3>(*b.hz));
  EXPECT_EQ(testing::SortedNames(dir.path()),
            (std::vector<std::string>{"v.f1", "v.nrrd", "v.sdb", "w.sdb"}));
}

// The direct build (the field in memory, diamond errors octave by octave)
// against the per-node engine's errors folded by ConvertToHz, with float32
// errors: the same field, the same errors up to their rounding, on cubic,
// padded and 4D grids; and a volume with missing values, which takes the
// engine's path, the same store as ConvertToHz's.
template <int D>
void ExpectDirectBuildMatchesTheEngine(const TestVolume& v, const std::string& name) {
  SCOPED_TRACE(name);
  TempDir dir;
  HzBuildOptions options;
  options.quantization = Quantization::kF32;
  const Built b = Build(v, dir, name, options);
  const auto built = BuildHzStore(*OpenVolume(dir / (name + ".nrrd")), dir / "direct.sdb", options);
  ASSERT_TRUE(built.ok()) << built.status().message();
  auto direct = HzStore::Open(dir / "direct.sdb");
  ASSERT_TRUE(direct.ok()) << direct.status().message();
  ASSERT_TRUE((*direct)->Verify().ok());
  HzStore::Reader<D> got(**direct), want(*b.hz);
  const double range = b.hz->header().field_max - b.hz->header().field_min;
  ForEachInternalCode<D>(b.hz->header().leaf_level(), [&](SimplexCode<D> c) {
    ASSERT_NEAR(*got.ErrorBound(c), *want.ErrorBound(c), 1e-6 * range) << c.ToString();
  });
  ExpectFields<D>(**direct, v);

  // Quantized to 16 bits, read through a cache and in memory (every finest
  // error computed at open), by node and by the threshold query's lookup
  // (the finest octave by vertex): the same bounds, at most a quantum above
  // the float32 ones.
  options.quantization = Quantization::kU16;
  ASSERT_TRUE(BuildHzStore(*OpenVolume(dir / (name + ".nrrd")), dir / "u16.sdb", options).ok());
  auto cached = HzStore::Open(dir / "u16.sdb");
  ASSERT_TRUE(cached.ok()) << cached.status().message();
  HzStore::Options in_memory;
  in_memory.in_memory = true;
  auto resident = HzStore::Open(dir / "u16.sdb", in_memory);
  ASSERT_TRUE(resident.ok()) << resident.status().message();
  ASSERT_TRUE((*resident)->Verify().ok());
  const double quantum = (*cached)->header().quantum;
  HzStore::Reader<D> u16(**cached), u16_resident(**resident);
  ForEachInternalCode<D>(b.hz->header().leaf_level(), [&](SimplexCode<D> c) {
    const double e = *u16.ErrorBound(c), f32 = *want.ErrorBound(c);
    ASSERT_GE(e, f32 - 1e-6 * range) << c.ToString();
    ASSERT_LE(e, f32 + quantum + 1e-6 * range) << c.ToString();
    ASSERT_EQ(*u16_resident.ErrorBound(c), e) << c.ToString();
    // A threshold answer is the bound, or a brick's or block's maximum
    // (at least the bound) when that is at most the threshold.
    for (const double t : {0.0, e / 2, e}) {
      for (HzStore::Reader<D>* r : {&u16, &u16_resident}) {
        const double a = *r->ErrorBoundForThreshold(c, t);
        ASSERT_GE(a, e) << c.ToString() << " threshold " << t;
        if (e > t) {
          ASSERT_EQ(a, e) << c.ToString() << " threshold " << t;
        } else {
          ASSERT_LE(a, t) << c.ToString() << " threshold " << t;
        }
      }
    }
  });
}

TEST(HzStore, DirectBuildMatchesTheEngine) {
  ExpectDirectBuildMatchesTheEngine<3>(TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kF32, 31), "ht17");
  ExpectDirectBuildMatchesTheEngine<3>(TestVolume::Random(3, {21, 7, 12, 1}, VoxelType::kU8, 32), "ht_padded");
  // A domain whose every octave fits in block 0 (D k < block bits): the
  // finest octave's part of it is not stored.
  ExpectDirectBuildMatchesTheEngine<3>(TestVolume::Random(3, {9, 8, 7, 1}, VoxelType::kF32, 36), "ht9");
  ExpectDirectBuildMatchesTheEngine<4>(TestVolume::Random(4, {5, 4, 5, 3}, VoxelType::kU8, 37), "hp5");
  ExpectDirectBuildMatchesTheEngine<4>(TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 33), "hp9");
  ExpectDirectBuildMatchesTheEngine<4>(TestVolume::Random(4, {7, 10, 5, 3}, VoxelType::kF32, 34), "hp_short");
}

// A store written in runs (blocks and bricks in two or three runs each,
// later ones first) answers as the store whose errors it copies; Finish
// refuses a store with a brick missing, and a writer dropped unfinished
// leaves nothing.
TEST(HzStore, WriterTakesBlocksAndBricksInRunsInAnyOrder) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {21, 17, 40, 1}, VoxelType::kU8, 41);
  HzBuildOptions o;
  o.quantization = Quantization::kF32;  // copied exactly (errors_are_bounds)
  o.block_bits = 6;                      // many blocks
  const Built b = Build(v, dir, "v", o);
  const HzHeader& ref = b.hz->header();
  const HzFill fill = [&](int, uint64_t first, size_t count, double* errors) -> Status {
    const std::optional<uint64_t> stored = b.hz->StoredIndex(first >> ref.block_bits);
    if (!stored) return Status::OK();  // zeros
    SDB_ASSIGN_OR_RETURN(const HzStore::BlockHandle h, b.hz->Block(*stored));
    for (size_t i = 0; i < count; ++i) {
      errors[i] = b.hz->quantizer().Decode(b.hz->StoredErrorAt(h.data, static_cast<uint32_t>(i)));
    }
    return Status::OK();
  };
  HzWriteOptions w;
  w.errors_are_bounds = true;
  w.threads = 2;
  {
    auto unfinished = HzStoreWriter::Create(dir / "unfinished.sdb", ref, w);
    ASSERT_TRUE(unfinished.ok()) << unfinished.status().message();
    std::vector<uint64_t> all((*unfinished)->candidate_blocks().size());
    for (uint64_t i = 0; i < all.size(); ++i) all[i] = i;
    ASSERT_TRUE((*unfinished)->WriteBlocks(all, fill).ok());
    const Result<HzHeader> refused = (*unfinished)->Finish();
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.status().message().find("brick 0 was not written"), std::string_view::npos)
        << refused.status().message();
  }
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename().string().find("unfinished"), std::string::npos) << entry.path();
  }

  auto writer = HzStoreWriter::Create(dir / "runs.sdb", ref, w);
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  HzStoreWriter& out = **writer;
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

  auto runs = HzStore::Open(dir / "runs.sdb");
  ASSERT_TRUE(runs.ok()) << runs.status().message();
  ASSERT_TRUE((*runs)->Verify().ok());
  EXPECT_EQ((*runs)->stored_blocks(), b.hz->stored_blocks());
  HzStore::Reader<3> got(**runs), want(*b.hz);
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
  HzHeader params;
  params.dimension = static_cast<uint8_t>(D);
  params.domain_bits = static_cast<uint8_t>(std::max(1, DomainBitsFor(D, dims)));
  params.block_bits = static_cast<uint8_t>(block_bits);
  params.brick_bits = static_cast<uint8_t>(HzDefaultBrickBits(D));
  params.dims = dims;
  params.field_max = 1;
  auto writer = HzStoreWriter::Create(dir / "s.sdb", params, HzWriteOptions{});
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  const HzHeader& h = (*writer)->header();
  const HzOrder<D> order(h.domain_bits);
  const std::set<uint64_t> candidates((*writer)->candidate_blocks().begin(),
                                      (*writer)->candidate_blocks().end());
  int spans = 0;
  for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
    const HzStoreWriter::BlockSpan span = (*writer)->SpanOf(b);
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

TEST(HzStore, BlockSpansHoldTheirVertices) {
  ExpectBlockSpans<3>({21, 17, 13, 1}, 6);
  ExpectBlockSpans<3>({33, 9, 20, 1}, 7);
  ExpectBlockSpans<4>({9, 5, 7, 6}, 6);
  ExpectBlockSpans<4>({9, 9, 5, 9}, 7);
}

// The streamed build (a window of planes at a time) makes the store the
// direct build makes, answer for answer: every node's bound, every field
// value, the grid bricks' finest maxima (Verify), HT and HP, integer and
// float voxels, non-cubic, several slabs and chunks. The check visits every
// node of the padded domain: its cost is the domain's (2^(D k) nodes), not
// the grid's.
template <int D>
void ExpectStreamedBuildMatchesDirect(const TestVolume& v, const std::string& name, int block_bits) {
  SCOPED_TRACE(name);
  TempDir dir;
  const std::string nrrd = dir / (name + ".nrrd");
  ASSERT_TRUE(v.WriteNrrd(nrrd).ok());
  HzBuildOptions options;
  options.block_bits = block_bits;
  const auto direct = BuildHzStore(*OpenVolume(nrrd), dir / "direct.sdb", options);
  ASSERT_TRUE(direct.ok()) << direct.status().message();
  ASSERT_STREQ(direct->method, "diamonds");
  options.stream = true;
  const auto streamed = BuildHzStore(*OpenVolume(nrrd), dir / "streamed.sdb", options);
  ASSERT_TRUE(streamed.ok()) << streamed.status().message();
  ASSERT_STREQ(streamed->method, "streamed");
  auto a = HzStore::Open(dir / "direct.sdb");
  auto b = HzStore::Open(dir / "streamed.sdb");
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_TRUE((*b)->Verify().ok());
  EXPECT_EQ((*b)->header().field_min, (*a)->header().field_min);
  EXPECT_EQ((*b)->header().field_max, (*a)->header().field_max);
  EXPECT_EQ((*b)->stored_blocks(), (*a)->stored_blocks());
  HzStore::Reader<D> want(**a), got(**b);
  ForEachInternalCode<D>((*a)->header().leaf_level(), [&](SimplexCode<D> c) {
    ASSERT_EQ(*got.ErrorBound(c), *want.ErrorBound(c)) << c.ToString();
  });
  for (uint64_t brick = 0; brick < (*a)->bricks(); ++brick) {
    ASSERT_EQ((*b)->brick_entry(brick).error_max, (*a)->brick_entry(brick).error_max) << brick;
  }
  ExpectFields<D>(**b, v);
}

// HT slabs are 64 planes with a halo of 32, HP slabs 32 with a halo of 8
// (hz_builder.cc). At domain side 128 (HT) and 32 (HP) the default cases
// cross slabs: 2 and 3 HT slabs (the second with local chunks of 128 and
// 256 planes spanning them), 2 HP slabs (the second holds the last plane
// only). The long run (SIMPLEXDB_LONG, `ctest -L long`) adds a side of 256
// (HT, a third scanned scale) and of 64 (HP, a second slab of 8 real
// planes): 8 and 16 times the nodes, minutes.
TEST(HzStore, StreamedBuildMatchesDirectHt) {
  ExpectStreamedBuildMatchesDirect<3>(TestVolume::Random(3, {65, 40, 77, 1}, VoxelType::kU8, 51), "ht_u8", 6);
  ExpectStreamedBuildMatchesDirect<3>(TestVolume::Random(3, {70, 66, 129, 1}, VoxelType::kF32, 52), "ht_f32", 9);
  if (testing::LongRun()) {
    ExpectStreamedBuildMatchesDirect<3>(TestVolume::Random(3, {70, 66, 150, 1}, VoxelType::kF32, 52),
                                        "ht_f32_256", 9);
  }
}
TEST(HzStore, StreamedBuildMatchesDirectHp) {
  ExpectStreamedBuildMatchesDirect<4>(TestVolume::Random(4, {33, 17, 20, 9}, VoxelType::kI16, 53), "hp_i16", 6);
  ExpectStreamedBuildMatchesDirect<4>(TestVolume::Random(4, {9, 12, 10, 33}, VoxelType::kF32, 54), "hp_long_t", 6);
  if (testing::LongRun()) {
    ExpectStreamedBuildMatchesDirect<4>(TestVolume::Random(4, {9, 12, 10, 40}, VoxelType::kF32, 54),
                                        "hp_long_t_64", 6);
  }
}

// The direct build reads the field in chunks of 2^20 voxels on every
// worker; a value no store can hold is still reported as a one-thread read
// would: the first in file order (chunk 0 here, though chunk 2 holds one too
// and is shorter).
TEST(HzStore, TheFirstBadValueInFileOrderIsReported) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {129, 129, 129, 1}, VoxelType::kF64, 38);
  v.values[1000000] = 1e39;                                      // (121, 11, 60)
  v.values[2100000] = std::numeric_limits<double>::infinity();  // (9, 25, 126)
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  HzBuildOptions options;
  options.threads = 2;
  const auto built = BuildHzStore(*OpenVolume(dir / "v.nrrd"), dir / "w.sdb", options);
  ASSERT_FALSE(built.ok());
  EXPECT_TRUE(built.status().IsInvalidArgument()) << built.status().ToString();
  EXPECT_NE(built.status().message().find("value 1e+39 at voxel (121, 11, 60) is beyond float32's range"),
            std::string_view::npos)
      << built.status().ToString();
  EXPECT_EQ(testing::SortedNames(dir.path()), (std::vector<std::string>{"v.nrrd"}));
}

TEST(HzStore, MissingValuesTakeTheEnginesPath) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {11, 13, 9, 1}, VoxelType::kF32, 35);
  for (size_t i = 0; i < v.values.size(); i += 17) v.values[i] = std::nan("");
  const Built b = Build(v, dir, "v");
  const auto built = BuildHzStore(*OpenVolume(dir / "v.nrrd"), dir / "w.sdb", HzBuildOptions{});
  ASSERT_TRUE(built.ok()) << built.status().message();
  auto w = HzStore::Open(dir / "w.sdb");
  ASSERT_TRUE(w.ok()) << w.status().message();
  HzStore::Reader<3> got(**w), want(*b.hz);
  ForEachInternalCode<3>(b.hz->header().leaf_level(), [&](SimplexCode<3> c) {
    ASSERT_EQ(*got.ErrorBound(c), *want.ErrorBound(c)) << c.ToString();
  });
}

// Every answer a store gives; nullopt when some lookup fails.
template <int D>
std::optional<std::vector<double>> AllAnswers(const HzStore& store) {
  HzStore::Reader<D> reader(store);
  std::vector<double> out;
  bool failed = false;
  ForEachInternalCode<D>(store.header().leaf_level(), [&](SimplexCode<D> c) {
    if (failed) return;
    const Result<double> e = reader.ErrorBound(c);
    const Result<double> t = reader.ErrorBoundForThreshold(c, 3.0);
    if (!e.ok() || !t.ok()) {
      failed = true;
      return;
    }
    out.push_back(*e);
    out.push_back(*t);
  });
  // Every real grid point's field, x fastest.
  const HzHeader& h = store.header();
  std::array<int64_t, D> p{};
  while (!failed) {
    const Result<double> f = reader.Field(p);
    if (!f.ok()) failed = true;
    else out.push_back(*f);
    int a = 0;
    for (; a < D; ++a) {
      if (++p[a] < int64_t{h.dims[a]}) break;
      p[a] = 0;
    }
    if (a == D) break;
  }
  if (failed) return std::nullopt;
  return out;
}

// Bit flips, byte overwrites and truncations anywhere: each is detected
// (open, a lookup or Verify fails) or harmless (the same answers), and with
// its checksums repaired fails cleanly or answers. Run in the sanitizer
// build too: nothing may crash or read out of bounds.
// `direct`: the store built from the field (finest errors computed by the
// reader), else through ConvertToHz (every error stored).
template <int D>
void DamageCampaign(const TestVolume& volume, Compression compression, int block_bits,
                    uint64_t seed, int cases, bool direct) {
  TempDir dir;
  HzBuildOptions o;
  o.compression = compression;
  o.block_bits = block_bits;
  const Built b = Build(volume, dir, "good", o);
  if (direct) {
    ASSERT_TRUE(BuildHzStore(*OpenVolume(dir / "good.nrrd"), dir / "good.sdb", o).ok());
  }
  auto good = HzStore::Open(dir / "good.sdb");
  ASSERT_TRUE(good.ok()) << good.status().message();
  ASSERT_EQ((*good)->header().finest_stored(), !direct);
  const auto truth = AllAnswers<D>(**good);
  ASSERT_TRUE(truth.has_value());
  const std::vector<uint8_t> bytes = ReadFileBytes(dir / "good.sdb");
  good->reset();
  std::mt19937_64 rng(seed);
  int detected = 0, harmless = 0;
  for (int i = 0; i < cases; ++i) {
    std::vector<uint8_t> damaged = bytes;
    size_t size = damaged.size();
    const int kind = static_cast<int>(rng() % 3);
    const size_t at = rng() % damaged.size();
    if (kind == 0) {
      damaged[at] ^= static_cast<uint8_t>(1u << (rng() % 8));
    } else if (kind == 1) {
      damaged[at] = static_cast<uint8_t>(rng());
    } else {
      size = at;
    }
    damaged.resize(size);
    // The same damage behind repaired checksums reaches the structural
    // checks: it may change answers, but must fail cleanly if at all.
    std::vector<uint8_t> repaired = damaged;
    fuzz::RepairHzChecksums(repaired);
    const std::string path = dir / "damaged.sdb";
    WriteBytes(path, repaired);
    if (auto store = HzStore::Open(path); store.ok()) {
      (void)AllAnswers<D>(**store);
      (void)(*store)->Verify();
    } else {
      ASSERT_NE(store.status().message().find(path), std::string_view::npos)
          << store.status().ToString();
    }
    WriteBytes(path, damaged);
    HzStore::Options options;
    options.in_memory = i % 4 == 0;
    options.cache_bytes = 16 << 10;  // a few blocks: evictions too
    auto store = HzStore::Open(path, options);
    if (!store.ok()) {
      const Status& s = store.status();
      ASSERT_TRUE(s.IsCorruption() || s.IsInvalidArgument() || s.IsNotSupported()) << s.ToString();
      ASSERT_NE(s.message().find(path), std::string_view::npos) << "the message must name the file";
      ++detected;
      continue;
    }
    const auto answers = AllAnswers<D>(**store);
    const bool verified = (*store)->Verify().ok();
    if (!answers) {
      ASSERT_FALSE(verified) << "case " << i << ": a lookup failed but Verify passed";
      ++detected;
      continue;
    }
    if (!verified) {
      ++detected;
      continue;
    }
    ASSERT_EQ(*answers, *truth) << "case " << i << ": kind " << kind << " at byte " << at;
    ++harmless;  // a flip in reserved or unused bytes
  }
  EXPECT_GT(detected, cases * 3 / 4) << harmless << " harmless";
}

// 4 x 300 damaged stores, HT and HP, zstd and raw, finest errors computed
// and stored.
TEST(HzStore, DamagedHtZstdIsDetectedOrHarmless) {
  DamageCampaign<3>(TestVolume::Random(3, {13, 11, 9, 1}, VoxelType::kU8, 7), Compression::kZstd,
                    6, 11, 300, true);
}
TEST(HzStore, DamagedHtRawIsDetectedOrHarmless) {
  DamageCampaign<3>(TestVolume::Random(3, {9, 7, 12, 1}, VoxelType::kI16, 8), Compression::kNone,
                    6, 12, 300, false);
}
TEST(HzStore, DamagedHpZstdIsDetectedOrHarmless) {
  DamageCampaign<4>(TestVolume::Random(4, {5, 5, 4, 5}, VoxelType::kF32, 9), Compression::kZstd,
                    8, 13, 300, false);
}
TEST(HzStore, DamagedHpRawIsDetectedOrHarmless) {
  DamageCampaign<4>(TestVolume::Random(4, {5, 3, 5, 4}, VoxelType::kU16, 10), Compression::kNone,
                    8, 14, 300, true);
}

}  // namespace
}  // namespace simplexdb

namespace simplexdb {
namespace {

// Coarse reads from one lattice's bricks against the reader's Field, point
// by point: every lattice, the whole grid and a box inside it.
template <int D>
void ExpectLatticeReads(const TestVolume& v, const std::string& name) {
  SCOPED_TRACE(name);
  TempDir dir;
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  ASSERT_TRUE(BuildHzStore(*OpenVolume(dir / "v.nrrd"), dir / "v.sdb", HzBuildOptions{}).ok());
  const auto store = *HzStore::Open(dir / "v.sdb");
  HzStore::Reader<D> reader(*store);
  const HzHeader& h = store->header();
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

TEST(HzStore, LatticeReadsEqualTheFieldPointByPoint) {
  ExpectLatticeReads<3>(TestVolume::Random(3, {37, 21, 18, 1}, VoxelType::kU8, 41), "ht");
  ExpectLatticeReads<3>(TestVolume::Random(3, {9, 17, 5, 1}, VoxelType::kF32, 42), "ht_float");
  ExpectLatticeReads<4>(TestVolume::Random(4, {11, 9, 5, 7}, VoxelType::kI16, 43), "hp");
}

}  // namespace
}  // namespace simplexdb
