// The sparse store of format 2 against the dense store of format 2 and
// against brute force: lossless, every node's bound and every grid point's
// value are the dense store's; at a tolerance t, every value is within t of
// the input, a dropped node's brute-force error is within t, a kept node's
// bound is at least its brute-force error, and the kept diamonds are closed
// under ancestors. Then damage: no crash, every case reported or answering
// as the undamaged store.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <random>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/io/checksum.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"
#include "util/little_endian.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// Noise in a box, an exactly linear ramp elsewhere (dropped when lossless),
// so a store keeps some diamonds and drops others.
TestVolume BoxInRamp(int dimension, std::array<uint32_t, 4> dims, VoxelType type, uint64_t seed) {
  TestVolume v = TestVolume::Random(dimension, dims, type, seed);
  for (uint64_t i = 0; i < v.values.size(); ++i) {
    uint64_t rest = i;
    std::array<int64_t, 4> p{};
    for (int a = 0; a < 4; ++a) {
      p[a] = static_cast<int64_t>(rest % dims[a]);
      rest /= dims[a];
    }
    bool in_box = true;
    for (int a = 0; a < dimension; ++a) in_box = in_box && p[a] >= 2 && p[a] <= 4;
    if (!in_box) v.values[i] = static_cast<double>(p[0] + 2 * p[1] + p[2] + p[3]);
  }
  return v;
}

// Every node above the leaf level, by level.
template <int D, class F>
void ForEachNode(int k, F&& f) {
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < D * k; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) f(SimplexCode<D>::FromPath(top, p, l));
    }
  }
}

// Every real grid point.
template <int D, class F>
void ForEachPoint(const TestVolume& v, F&& f) {
  std::array<int64_t, D> p{};
  while (true) {
    f(p);
    int a = 0;
    for (; a < D; ++a) {
      if (++p[a] < static_cast<int64_t>(v.dims[a])) break;
      p[a] = 0;
    }
    if (a == D) break;
  }
}

struct Stores {
  std::unique_ptr<DenseStore> dense;
  std::unique_ptr<SparseStore> sparse;
  SparseBuildReport report;
};

Stores Build(const TestVolume& volume, const TempDir& dir, double tolerance, int block_bits = 0) {
  const std::string nrrd = dir / "in.nrrd";
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  Stores s;
  DenseBuildOptions dense;
  dense.threads = 1;
  const auto built = BuildDenseStore(*OpenVolume(nrrd), dir / "dense.sdb", dense);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  s.dense = *DenseStore::Open(dir / "dense.sdb");
  SparseBuildOptions o;
  o.tolerance = tolerance;
  o.block_bits = block_bits;
  o.threads = 2;
  const auto report = BuildSparseStore(*OpenVolume(nrrd), dir / "sparse.sdb", o);
  EXPECT_TRUE(report.ok()) << report.status().ToString();
  if (report.ok()) s.report = *report;
  auto opened = SparseStore::Open(dir / "sparse.sdb", {});
  EXPECT_TRUE(opened.ok()) << opened.status().ToString();
  if (opened.ok()) s.sparse = *std::move(opened);
  return s;
}

template <int D>
void ExpectLosslessIsDense(const TestVolume& volume, int block_bits) {
  TempDir dir;
  const Stores s = Build(volume, dir, 0, block_bits);
  ASSERT_NE(s.sparse, nullptr);
  EXPECT_TRUE(s.sparse->Verify().ok());
  const int k = s.dense->header().domain_bits;
  ASSERT_EQ(s.sparse->header().domain_bits, k);
  DenseStore::Reader<D> dense(*s.dense);
  SparseStore::Reader<D> sparse(*s.sparse);
  uint64_t nodes = 0, dropped = 0;
  ForEachNode<D>(k, [&](SimplexCode<D> c) {
    const double want = *dense.ErrorBound(c);
    const Result<double> got = sparse.ErrorBound(c);
    ASSERT_TRUE(got.ok()) << got.status().ToString();
    ASSERT_EQ(*got, want) << c.ToString();
    ++nodes;
    dropped += want == 0;
  });
  ForEachPoint<D>(volume, [&](const std::array<int64_t, D>& p) {
    std::array<int64_t, 4> q{};
    for (int a = 0; a < D; ++a) q[a] = p[a];
    ASSERT_EQ(*sparse.Field(p), volume.At(q));
  });
  // The ramp drops diamonds, the box keeps some: both kinds were checked.
  EXPECT_GT(dropped, 0u);
  EXPECT_LT(dropped, nodes);
  EXPECT_LT(s.sparse->header().kept, nodes);
}

TEST(SparseStore, LosslessIsTheDenseStoreHt) {
  ExpectLosslessIsDense<3>(BoxInRamp(3, {13, 9, 17, 1}, VoxelType::kU8, 1), 0);
  ExpectLosslessIsDense<3>(BoxInRamp(3, {9, 9, 9, 1}, VoxelType::kI16, 2), 6);
  ExpectLosslessIsDense<3>(BoxInRamp(3, {11, 6, 14, 1}, VoxelType::kF32, 3), 9);
}
TEST(SparseStore, LosslessIsTheDenseStoreHp) {
  ExpectLosslessIsDense<4>(BoxInRamp(4, {5, 6, 4, 5}, VoxelType::kU16, 4), 0);
  ExpectLosslessIsDense<4>(BoxInRamp(4, {5, 5, 5, 3}, VoxelType::kF64, 5), 8);
}

template <int D>
void ExpectWithinTolerance(const TestVolume& volume, double tolerance, int block_bits) {
  SCOPED_TRACE("tolerance " + std::to_string(tolerance));
  TempDir dir;
  const Stores s = Build(volume, dir, tolerance, block_bits);
  ASSERT_NE(s.sparse, nullptr);
  EXPECT_TRUE(s.sparse->Verify().ok());
  const int k = s.sparse->header().domain_bits;
  // Kept values are stepped (the lossy path is the one under test): read
  // back within s / 2 = t of the input, as the dropped ones are rebuilt.
  const SparseHeader& h = s.sparse->header();
  EXPECT_EQ(h.value_step, 2 * tolerance);
  EXPECT_GE(h.quantum, tolerance);
  SparseStore::Reader<D> sparse(*s.sparse);
  ForEachPoint<D>(volume, [&](const std::array<int64_t, D>& p) {
    std::array<int64_t, 4> q{};
    for (int a = 0; a < D; ++a) q[a] = p[a];
    ASSERT_LE(std::abs(*sparse.Field(p) - volume.At(q)), tolerance) << p[0] << "," << p[1] << "," << p[2];
  });
  uint64_t kept = 0, dropped = 0;
  ForEachNode<D>(k, [&](SimplexCode<D> c) {
    const double bound = *sparse.ErrorBound(c);
    const long double exact = testing::BruteForceError<D>(c, k, volume);
    const auto v = LatticeToGrid<D>(SplitVertex(c), k);
    const bool is_kept = *sparse.Kept(v);
    if (!is_kept) {
      ASSERT_EQ(bound, 0.0) << c.ToString();
      ASSERT_LE(static_cast<double>(exact), tolerance + 1e-9) << c.ToString();
      ++dropped;
      return;
    }
    ++kept;
    ASSERT_GE(bound, static_cast<double>(exact) - 1e-9) << c.ToString();
    // Closed under ancestors: the parent's diamond is kept too.
    if (c.level() > 0) {
      ASSERT_TRUE(*sparse.Kept(LatticeToGrid<D>(SplitVertex(c.parent()), k))) << c.ToString();
    }
  });
  EXPECT_GT(kept, 0u);
  EXPECT_GT(dropped, 0u);
}

TEST(SparseStore, WithinToleranceHt) {
  const TestVolume v = TestVolume::Random(3, {13, 9, 17, 1}, VoxelType::kU8, 6);
  ExpectWithinTolerance<3>(v, 40, 0);
  ExpectWithinTolerance<3>(v, 90, 7);
  ExpectWithinTolerance<3>(BoxInRamp(3, {10, 12, 9, 1}, VoxelType::kF32, 7), 3.5, 0);
}
TEST(SparseStore, WithinToleranceHp) {
  ExpectWithinTolerance<4>(TestVolume::Random(4, {5, 6, 4, 5}, VoxelType::kU8, 8), 60, 0);
}

// A kept value at step s: read back within s / 2, the residual zigzagged
// into 4 bytes, both signs, up to the magnitudes SparseValueStep allows.
TEST(SparseStore, StepResidualsReadBackWithinHalfAStep) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> unit(-1, 1);
  for (const double step : {0.1, 1.0, 5.1, 1e-6, 3e5}) {
    for (const double reach : {0.0, 0.5, 3.0, 1e3, 0x1p28}) {
      for (int i = 0; i < 200; ++i) {
        const double p = unit(rng) * 1e3 * step;
        const double value = p + unit(rng) * reach * step;
        double back = 0;
        const uint64_t r = HzStepResidual(value, p, step, &back);
        ASSERT_LT(r, uint64_t{1} << 32);
        ASSERT_LE(std::abs(back - value), step / 2) << value << " " << p << " " << step;
        ASSERT_EQ(HzFromStepResidual(r, p, step), back);
        // Zigzag: a residual of k steps is 2k or -2k - 1.
        const double k = std::round((back - p) / step);
        ASSERT_EQ(static_cast<double>(r), k >= 0 ? 2 * k : -2 * k - 1);
      }
    }
  }
  // Steps: 2t, but exact at t = 0, below an integer type's step of 1, and
  // where the field's magnitude over the step passes 2^29.
  EXPECT_EQ(SparseValueStep(VoxelType::kU8, 2.5, 0, 255), 5.0);
  EXPECT_EQ(SparseValueStep(VoxelType::kU8, 0, 0, 255), 0.0);
  EXPECT_EQ(SparseValueStep(VoxelType::kU16, 0.4, 0, 65535), 0.0);
  EXPECT_EQ(SparseValueStep(VoxelType::kF32, 0.4, 0, 1), 0.8);
  EXPECT_EQ(SparseValueStep(VoxelType::kF32, 1e-9, 0, 1), 0.0);
  EXPECT_EQ(SparseValueStep(VoxelType::kF64, 1.0, 1e12, 1e12 + 10), 0.0);
}

// The header's value step is the tolerance's (SparseValueStep): one that
// is missing or another is damage.
TEST(SparseStore, HeaderValueStep) {
  SparseHeader h;
  h.dims = {5, 5, 5, 1};
  h.domain_bits = 2;
  h.field_max = 255;
  h.quantum = 2;
  h.tolerance = 2;
  h.value_step = 4;
  std::vector<uint8_t> value = EncodeSparseHeader(h);
  Result<SparseHeader> back = DecodeSparseHeader(value, "h");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->value_step, 4.0);
  const auto rewritten = [&](const std::string& from, const std::string& to) {
    std::string text(value.begin(), value.end() - 8);
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::vector<uint8_t> out(text.begin(), text.end());
    const uint64_t sum = Checksum(std::span<const uint8_t>(out.data(), out.size()));
    for (int i = 0; i < 8; ++i) out.push_back(static_cast<uint8_t>(sum >> (8 * i)));
    return out;
  };
  EXPECT_TRUE(DecodeSparseHeader(rewritten("\"value_step\": 4.0,", ""), "h").status().IsCorruption());
  EXPECT_TRUE(DecodeSparseHeader(rewritten("\"value_step\": 4.0", "\"value_step\": 3.0"), "h")
                  .status()
                  .IsCorruption());
  EXPECT_TRUE(DecodeSparseHeader(rewritten("\"value_step\": 4.0", "\"value_step\": 0.0"), "h")
                  .status()
                  .IsCorruption());
}

// The origin round-trips; a header without it (stores written before it
// was added, same version) reads as zeros; a wrong count is damage.
TEST(SparseStore, HeaderOriginIsOptional) {
  SparseHeader h;
  h.dimension = 4;
  h.dims = {5, 5, 5, 3};
  h.domain_bits = 2;
  h.field_max = 255;
  h.quantum = 2;
  h.spacing = {2, 2, 2.2, 2};
  h.origin = {117.855, -35.7229, -7.25, 0.5};
  const std::vector<uint8_t> value = EncodeSparseHeader(h);
  Result<SparseHeader> back = DecodeSparseHeader(value, "h");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->spacing, h.spacing);
  EXPECT_EQ(back->origin, h.origin);
  const auto resealed = [](std::string text) {
    std::vector<uint8_t> out(text.begin(), text.end());
    const uint64_t sum = Checksum(std::span<const uint8_t>(out.data(), out.size()));
    for (int i = 0; i < 8; ++i) out.push_back(static_cast<uint8_t>(sum >> (8 * i)));
    return out;
  };
  std::string text(value.begin(), value.end() - 8);
  const size_t from = text.find("\"origin\"");
  ASSERT_NE(from, std::string::npos) << text;
  const size_t to = text.find("],", from);
  ASSERT_NE(to, std::string::npos);
  std::string without = text;
  without.erase(from, to + 2 - from);
  ASSERT_EQ(without.find("origin"), std::string::npos) << without;
  back = DecodeSparseHeader(resealed(without), "old");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->origin, (std::array<double, 4>{0, 0, 0, 0}));
  EXPECT_EQ(back->spacing, h.spacing);
  std::string three = text;
  three.replace(from, to + 1 - from, "\"origin\": [1, 2, 3]");
  back = DecodeSparseHeader(resealed(three), "bad");
  ASSERT_FALSE(back.ok());
  EXPECT_TRUE(back.status().IsCorruption()) << back.status().ToString();
  EXPECT_NE(back.status().message().find("origin"), std::string::npos);
}

TEST(SparseStore, RefusesBadInput) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {5, 5, 5, 1}, VoxelType::kU8, 9);
  ASSERT_TRUE(v.WriteNrrd(dir / "in.nrrd").ok());
  SparseBuildOptions o;
  o.tolerance = -1;
  EXPECT_TRUE(BuildSparseStore(*OpenVolume(dir / "in.nrrd"), dir / "a.sdb", o).status().IsInvalidArgument());
  o.tolerance = 0;
  o.block_bits = 30;
  EXPECT_TRUE(BuildSparseStore(*OpenVolume(dir / "in.nrrd"), dir / "a.sdb", o).status().IsInvalidArgument());
  o.block_bits = 0;
  o.memory_bytes = 1000;
  const Status small = BuildSparseStore(*OpenVolume(dir / "in.nrrd"), dir / "a.sdb", o).status();
  EXPECT_TRUE(small.IsResourceExhausted()) << small.ToString();
  EXPECT_FALSE(std::filesystem::exists(dir / "a.sdb"));
  // Not a store at all.
  std::ofstream(dir / "junk.sdb") << "not a store";
  EXPECT_FALSE(SparseStore::Open(dir / "junk.sdb", {}).ok());
}

// LMDB's page kinds, from each page's header (flags at byte 10; pages 0
// and 1 are the metas; an overflow run's later pages have no header): the
// test aims its damage at each kind by what the file says, not by what
// the code under test reads.
enum PageKind { kMetaPage, kBranchPage, kLeafPage, kOverflowPage, kPageKinds };
const char* const kPageKindNames[] = {"meta", "branch", "leaf", "overflow"};

std::array<std::vector<size_t>, kPageKinds> PagesByKind(const std::vector<uint8_t>& file) {
  std::array<std::vector<size_t>, kPageKinds> out;
  const size_t page = LoadLittle<uint32_t>(file.data() + 40);  // the free database's md_pad
  EXPECT_TRUE(page >= 4096 && page <= 32768 && std::has_single_bit(page)) << page;
  for (size_t p = 0; (p + 1) * page <= file.size();) {
    const uint16_t flags = LoadLittle<uint16_t>(file.data() + p * page + 10);
    if (flags & 0x08) out[kMetaPage].push_back(p);
    if (flags & 0x01) out[kBranchPage].push_back(p);
    if (flags & 0x02) out[kLeafPage].push_back(p);
    size_t run = 1;
    if (flags & 0x04) {
      run = std::max<size_t>(1, LoadLittle<uint32_t>(file.data() + p * page + 12));
      for (size_t q = p; q < p + run; ++q) out[kOverflowPage].push_back(q);
    }
    p += run;
  }
  return out;
}

// Damage to built stores' files: bit flips, byte runs overwritten and
// truncations, aimed in turn at meta, branch and leaf pages (two stores:
// small blocks, many entries, and large ones, each value in several parts;
// parts keep every value inside leaf pages, so the files have no overflow
// pages, which is checked). Open or Verify reports it, or
// every answer is the undamaged store's. (The LMDB layer's own damage
// tests, storage/io/lmdb_check_test.cc, run the cases in child processes;
// these run in process: a crash fails the whole test.) The count is
// SIMPLEXDB_DAMAGE_CASES (default 150; the `long` test SparseDamageLong
// runs 1000: `ctest --test-dir build/asan -R SparseDamageLong`).
TEST(SparseStore, DamageIsReportedOrHarmless) {
  const char* env_cases = std::getenv("SIMPLEXDB_DAMAGE_CASES");
  const int cases = env_cases != nullptr ? std::atoi(env_cases) : 150;
  struct Target {
    TestVolume volume;
    int block_bits;
  };
  const Target targets[] = {{BoxInRamp(3, {13, 9, 17, 1}, VoxelType::kU8, 10), 5},
                            {TestVolume::Random(3, {20, 17, 19, 1}, VoxelType::kF32, 13), 12}};
  std::array<int, kPageKinds> aimed{};
  int reported = 0, harmless = 0, trial = 0;
  std::mt19937_64 rng(11);
  for (const Target& target : targets) {
    TempDir dir;
    const TestVolume& v = target.volume;
    const Stores s = Build(v, dir, 0, target.block_bits);
    ASSERT_NE(s.sparse, nullptr);
    const int k = s.sparse->header().domain_bits;
    std::vector<double> want;
    {
      SparseStore::Reader<3> r(*s.sparse);
      ForEachNode<3>(k, [&](SimplexCode<3> c) { want.push_back(*r.ErrorBound(c)); });
      ForEachPoint<3>(v, [&](const std::array<int64_t, 3>& p) { want.push_back(*r.Field(p)); });
    }
    const std::vector<uint8_t> good = testing::ReadFileBytes(dir / "sparse.sdb");
    ASSERT_FALSE(good.empty());
    const auto pages = PagesByKind(good);
    EXPECT_TRUE(pages[kOverflowPage].empty()) << "a block's part in overflow pages";
    const size_t page_bytes = LoadLittle<uint32_t>(good.data() + 40);
    for (int n = 0; n < cases / 2; ++n, ++trial) {
      // The next page kind this store has, a page of it, a byte in it.
      int kind = trial % kPageKinds;
      while (pages[kind].empty()) kind = static_cast<int>(rng() % kOverflowPage);
      ++aimed[kind];
      const size_t page = pages[kind][rng() % pages[kind].size()];
      const size_t at = page * page_bytes + rng() % page_bytes;
      std::vector<uint8_t> bad = good;
      const int how = (trial / kPageKinds) % 3;
      if (how == 0) {  // one bit
        bad[at] ^= static_cast<uint8_t>(1u << (rng() % 8));
      } else if (how == 1) {  // a run of bytes
        for (size_t i = at; i < std::min(bad.size(), at + 1 + rng() % 64); ++i) bad[i] = static_cast<uint8_t>(rng());
      } else {  // cut short
        bad.resize(at);
      }
      const std::string path = dir / ("bad" + std::to_string(trial) + ".sdb");
      std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bad.data()),
                                                   static_cast<std::streamsize>(bad.size()));
      auto store = SparseStore::Open(path, {});
      if (!store.ok() || !(*store)->Verify().ok()) {
        ++reported;
        if (store.ok()) store->reset();
        std::filesystem::remove(path);
        std::filesystem::remove(path + "-lock");
        continue;
      }
      bool same = true;
      {
        SparseStore::Reader<3> r(**store);
        size_t i = 0;
        ForEachNode<3>(k, [&](SimplexCode<3> c) {
          const Result<double> e = r.ErrorBound(c);
          same = same && e.ok() && *e == want[i];
          ++i;
        });
        ForEachPoint<3>(v, [&](const std::array<int64_t, 3>& p) {
          const Result<double> f = r.Field(p);
          same = same && f.ok() && *f == want[i];
          ++i;
        });
      }
      EXPECT_TRUE(same) << "trial " << trial << " (" << kPageKindNames[kind]
                        << " page): verify passed but the answers changed";
      ++harmless;
      store->reset();
      std::filesystem::remove(path);
      std::filesystem::remove(path + "-lock");
    }
  }
  for (int kind = 0; kind < kOverflowPage; ++kind) {
    EXPECT_GT(aimed[kind], cases / 10) << kPageKindNames[kind] << " pages: too few cases";
  }
  EXPECT_GT(reported, cases / 3);
  EXPECT_GT(harmless, 0);
  std::printf("damage: %d reported, %d harmless; meta %d, branch %d, leaf %d, overflow %d cases\n", reported,
              harmless, aimed[kMetaPage], aimed[kBranchPage], aimed[kLeafPage], aimed[kOverflowPage]);
}

// Readers of one store share its cache and fill the finest codes into the
// cached blocks: two threads reading at once get one thread's answers.
TEST(SparseStore, TwoThreadsReadAsOne) {
  TempDir dir;
  const TestVolume v = BoxInRamp(3, {13, 9, 17, 1}, VoxelType::kU8, 12);
  const Stores s = Build(v, dir, 0, 6);
  ASSERT_NE(s.sparse, nullptr);
  const int k = s.sparse->header().domain_bits;
  std::vector<double> want;
  {
    auto alone = *SparseStore::Open(dir / "sparse.sdb", {});
    SparseStore::Reader<3> r(*alone);
    ForEachNode<3>(k, [&](SimplexCode<3> c) { want.push_back(*r.ErrorBound(c)); });
  }
  std::vector<double> got[2];
  const auto run = [&](int t) {
    SparseStore::Reader<3> r(*s.sparse);
    ForEachNode<3>(k, [&](SimplexCode<3> c) {
      const Result<double> e = r.ErrorBound(c);
      got[t].push_back(e.ok() ? *e : -1);
    });
  };
  std::thread a(run, 0), b(run, 1);
  a.join();
  b.join();
  EXPECT_EQ(got[0], want);
  EXPECT_EQ(got[1], want);
}

// Writes the LMDB file at `path` (with a map of `map_bytes`; 0: the size
// recorded in the file) in one transaction: write(txn) opens its databases
// and puts its entries.
void WriteLmdb(const std::string& path, uint64_t map_bytes, const std::function<void(lmdb::Txn&)>& write) {
  lmdb::Env::Options o;
  o.read_only = false;
  o.map_bytes = map_bytes;
  auto env = lmdb::Env::Open(path, o);
  ASSERT_TRUE(env.ok()) << env.status().ToString();
  auto txn = lmdb::Txn::Begin(**env, false);
  ASSERT_TRUE(txn.ok()) << txn.status().ToString();
  ASSERT_NO_FATAL_FAILURE(write(*txn));
  ASSERT_TRUE(txn->Commit().ok());
}

// Opening the store at `path` is refused as not supported, the message
// naming each of `words`.
void ExpectRefused(const std::string& path, std::initializer_list<std::string_view> words) {
  const Status s = SparseStore::Open(path, {}).status();
  EXPECT_TRUE(s.IsNotSupported()) << s.ToString();
  for (const std::string_view w : words) EXPECT_NE(s.message().find(w), std::string_view::npos) << s.ToString();
}

// The header of a store built in `dir`, at another version.
SparseHeader HeaderOfVersion(const TempDir& dir, uint32_t version) {
  Stores s = Build(BoxInRamp(3, {6, 5, 7, 1}, VoxelType::kU8, 14), dir, 0, 6);
  EXPECT_NE(s.sparse, nullptr);
  if (s.sparse == nullptr) return {};
  SparseHeader h = s.sparse->header();
  h.version = version;
  return h;  // the store closed: one environment per file and process (LMDB)
}

TEST(SparseStore, AFormatOneStoreIsRefused) {
  // An LMDB file with format 1's databases.
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteLmdb(dir / "old.sdb", 1 << 20, [](lmdb::Txn& txn) {
    for (const char* name : {"meta", "errors", "field"}) ASSERT_TRUE(txn.OpenDb(name, true).ok()) << name;
  }));
  ExpectRefused(dir / "old.sdb", {"import"});
}

// Header versions 2 and 3 kept the header in a database "meta" and the
// blocks in "blocks": refused, with the same advice.
TEST(SparseStore, AnEarlierLayoutIsRefused) {
  TempDir dir;
  const SparseHeader h = HeaderOfVersion(dir, 3);
  ASSERT_FALSE(HasFailure());
  ASSERT_NO_FATAL_FAILURE(WriteLmdb(dir / "old.sdb", 1 << 20, [&](lmdb::Txn& txn) {
    ASSERT_TRUE(txn.OpenDb("blocks", true).ok());
    const MDB_dbi meta = *txn.OpenDb("meta", true);
    ASSERT_TRUE(txn.Put(meta, kSparseHeaderKey, EncodeSparseHeader(h)).ok());
  }));
  ExpectRefused(dir / "old.sdb", {"version 2 or 3", "import the volume again"});
}

// A header of another version where this layout keeps it: refused too.
TEST(SparseStore, AnotherHeaderVersionIsRefused) {
  TempDir dir;
  const SparseHeader h = HeaderOfVersion(dir, 5);
  ASSERT_FALSE(HasFailure());
  ASSERT_NO_FATAL_FAILURE(WriteLmdb(dir / "sparse.sdb", 0, [&](lmdb::Txn& txn) {
    const MDB_dbi dbi = *txn.OpenDb(nullptr, false);
    ASSERT_TRUE(txn.Put(dbi, kSparseHeaderKey, EncodeSparseHeader(h)).ok());
  }));
  ExpectRefused(dir / "sparse.sdb", {"version 5", "import the volume again"});
}

}  // namespace
}  // namespace simplexdb
