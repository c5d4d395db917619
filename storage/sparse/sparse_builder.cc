#include "storage/sparse/sparse_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <thread>
#include <vector>

#include "hierarchy/hz_order.h"
#include "hierarchy/geometry.h"
#include "storage/common/field_loader.h"
#include "storage/common/parallel_run.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/finest_diamonds.h"
#include "storage/error/mask.h"
#include "storage/error/quantize.h"
#include "storage/io/file.h"
#include "storage/io/lmdb.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

// The vertices the build keeps arrays for: at each scale s (a vertex's
// trailing zero bits, the domain's corners k), the lattice points of stride
// 2^s within the real grid grown by kMargin << s per axis. A kept vertex is
// never farther: an error above t needs a real point in the diamond (2 << s
// away), and the vertices a kept diamond stands on lie within 2 << s of it,
// at its scale or coarser, which bounds the drift at about 4D << s.
template <int D>
class NearGrid {
 public:
  static constexpr int64_t kMargin = 4 * D + 2;
  static constexpr uint64_t kFar = ~uint64_t{0};

  NearGrid(const std::array<int64_t, D>& dims, int k) : k_(k) {
    for (int s = 0; s <= k; ++s) {
      offset_[s] = size_;
      uint64_t n = 1;
      for (int a = 0; a < D; ++a) {
        limit_[s][a] = std::min(int64_t{1} << k, dims[a] - 1 + (kMargin << s));
        count_[s][a] = (limit_[s][a] >> s) + 1;
        n *= static_cast<uint64_t>(count_[s][a]);
      }
      size_ += n;
    }
  }

  uint64_t size() const { return size_; }
  // The largest coordinate of a near vertex of scale s on axis a.
  int64_t limit(int s, int a) const { return limit_[s][a]; }

  uint64_t Index(const std::array<int64_t, D>& g) const {
    uint64_t any = 0;
    for (int a = 0; a < D; ++a) any |= static_cast<uint64_t>(g[a]);
    const int s = any == 0 ? k_ : std::min(k_, std::countr_zero(any));
    uint64_t i = 0;
    for (int a = D - 1; a >= 0; --a) {
      const int64_t c = g[a] >> s;
      if (g[a] < 0 || c >= count_[s][a]) return kFar;
      i = i * static_cast<uint64_t>(count_[s][a]) + static_cast<uint64_t>(c);
    }
    return offset_[s] + i;
  }

  // f(g) for every near vertex of creation level c (order.h's levels).
  template <class F>
  void ForEachAtLevel(int c, F&& f) const {
    const int o = c / D, m = D - c % D, s = k_ - 1 - o;
    for (uint32_t odd = 1; odd < (1u << D); ++odd) {
      if (std::popcount(odd) != m) continue;
      std::array<int64_t, D> last{}, u{};
      bool empty = false;
      for (int a = 0; a < D; ++a) {
        const int64_t lim = limit_[s][a] - ((odd >> a & 1) ? (int64_t{1} << s) : 0);
        last[a] = lim < 0 ? -1 : lim >> (s + 1);
        empty = empty || last[a] < 0;
      }
      if (empty) continue;
      while (true) {
        std::array<int64_t, D> g{};
        for (int a = 0; a < D; ++a) g[a] = (u[a] << (s + 1)) | (static_cast<int64_t>(odd >> a & 1) << s);
        f(g);
        int a = 0;
        for (; a < D; ++a) {
          if (++u[a] <= last[a]) break;
          u[a] = 0;
        }
        if (a == D) break;
      }
    }
  }

 private:
  int k_;
  uint64_t size_ = 0;
  std::array<uint64_t, 32> offset_{};
  std::array<std::array<int64_t, D>, 32> limit_{}, count_{};
};

template <int D>
class Builder {
 public:
  Builder(const VolumeInfo& input, const SparseBuildOptions& options, Clock::time_point start)
      : input_(input), options_(options), start_(start) {
    for (int a = 0; a < D; ++a) dims_[a] = input.dims[a];
    k_ = std::max(1, DomainBitsFor(D, input.dims));
    threads_ = options.threads > 0 ? options.threads
                                   : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    type_ = StoredVoxelType(input, false);
  }

  // Puts the blocks through `writer`, in key order; the header's counts in
  // `report`.
  Status Run(lmdb::BatchWriter& writer, MDB_dbi dbi, size_t page_bytes, SparseBuildReport* report) {
    const NearGrid<D> near(dims_, k_);
    const uint64_t points = input_.voxel_count();
    const uint64_t need = points * 8 + near.size() * (4 + 1 + 1 + 1 + 8 + 8);
    if (options_.memory_bytes > 0 && need > options_.memory_bytes) {
      return Status::ResourceExhausted(
          input_.description + ": a sparse store of it is built in memory and needs " +
          std::to_string((need + (1 << 20) - 1) >> 20) + " MiB; the budget (--memory-mb) is " +
          std::to_string(options_.memory_bytes >> 20) + " MiB");
    }
    SDB_RETURN_IF_ERROR(ReadField());
    SparseHeader& h = report->header;
    h.dimension = D;
    h.dims = input_.dims;
    h.domain_bits = k_;
    h.voxel_type = type_;
    h.quantization = options_.quantization;
    h.field_min = fmin_;
    h.field_max = fmax_;
    h.tolerance = options_.tolerance_percent ? options_.tolerance / 100 * (fmax_ - fmin_) : options_.tolerance;
    h.block_bits = options_.block_bits > 0 ? options_.block_bits : (D == 3 ? 18 : 20);
    h.spacing = input_.spacing;
    h.origin = input_.origin;
    h.source = DescribeSource(input_);
    h.source.resize(Utf8PrefixLength(h.source, 1000));
    const double range = fmax_ - fmin_;
    h.quantum = ErrorQuantizer::QuantumFor(h.quantization, range);
    // At a tolerance t, errors go up to the next multiple of t (u16, u8),
    // and past 8t to the next step of 25% (SparseErrorCoder): smaller
    // codes, and a query at a multiple of t up to 8t refines as with exact
    // errors (a code above its threshold is an error above it).
    if (h.tolerance > 0 && h.quantization != Quantization::kF32) h.quantum = std::max(h.quantum, h.tolerance);
    const SparseErrorCoder coder(h);

    // 0. Every near vertex's diamond error: its code as the dense store
    // stores it (the same double, the same quantizer: lossless stores answer
    // alike) and whether it exceeds t.
    const double t = h.tolerance;
    h.value_step = SparseValueStep(type_, t, fmin_, fmax_);
    const double step = h.value_step;
    std::vector<uint32_t> code(near.size(), 0);
    std::vector<uint8_t> above(near.size(), 0);
    {
      DiamondErrors<D, double> diamonds(field_.data(), dims_, k_, !IsFloatType(type_), range, threads_);
      diamonds.Allocate();
      SDB_RETURN_IF_ERROR(RunParallel(diamonds.item_count(), threads_, "errors", start_, options_.progress,
                                      [&](int worker, uint64_t item) {
                                        diamonds.ComputeItem(worker, item);
                                        return Status::OK();
                                      }));
      diamonds.Finish();
      const HzOrder<D> order(k_);
      const int levels = D * k_;
      std::vector<double> level_max(static_cast<size_t>(levels), 0.0);
      SDB_RETURN_IF_ERROR(RunParallel(static_cast<uint64_t>(levels), threads_, "errors", start_, {},
                                      [&](int, uint64_t c) {
                                        double& largest = level_max[c];
                                        near.ForEachAtLevel(static_cast<int>(c), [&](const std::array<int64_t, D>& g) {
                                          const double e = diamonds.At(g, order.PositionAtLevel(g, static_cast<int>(c)));
                                          const uint64_t i = near.Index(g);
                                          code[i] = coder.Encode(e);
                                          above[i] = e > t;
                                          largest = std::max(largest, e);
                                        });
                                        return Status::OK();
                                      }));
      for (const double e : level_max) h.error_max = std::max(h.error_max, e);
    }

    // 1-2. Keep and rebuild until every check holds.
    std::vector<uint8_t> kept(near.size()), force(near.size(), 0);
    std::vector<double> value(near.size(), 0.0);
    std::vector<uint64_t> residual(near.size(), 0);
    const auto at = [&](const std::array<int64_t, D>& g) { return value[near.Index(g)]; };
    const int levels = D * k_;
    while (true) {
      ++report->rounds;
      std::fill(kept.begin(), kept.end(), 0);
      Status far = Status::OK();
      for (int c = levels - 1; c >= 0; --c) {
        near.ForEachAtLevel(c, [&](const std::array<int64_t, D>& g) {
          const uint64_t i = near.Index(g);
          if (!kept[i] && !force[i] && !above[i]) return;
          kept[i] = 1;
          const DiamondShape sh = ShapeOfVertex<D>(g);
          for (const auto& w : FinestDiamonds<D>::Get().VertexOffsets(sh.odd, sh.parity)) {
            std::array<int64_t, D> q{};
            bool inside = true;
            for (int a = 0; a < D; ++a) {
              q[a] = g[a] + (int64_t{w[a]} << sh.scale_bits);
              inside = inside && q[a] >= 0 && q[a] <= (int64_t{1} << k_);
            }
            if (!inside) continue;
            const uint64_t j = near.Index(q);
            if (j == NearGrid<D>::kFar) {
              far = Status::NotSupported(input_.description + ": a kept diamond stands on a vertex past the sparse builder's work arrays (a SimplexDB bug; please report it)");
              continue;
            }
            kept[j] = 1;
          }
        });
      }
      SDB_RETURN_IF_ERROR(far);
      uint64_t failed = 0;
      // A kept value as a reader reads it back: exactly, or within s / 2.
      const auto keep = [&](uint64_t i, const std::array<int64_t, D>& g, double p) {
        if (step == 0) {
          value[i] = FieldAt(g);
          residual[i] = HzResidual(type_, value[i], p);
        } else {
          residual[i] = HzStepResidual(FieldAt(g), p, step, &value[i]);
        }
      };
      for (const auto& corner : Corners()) {
        const uint64_t i = near.Index(corner);
        kept[i] = 1;
        keep(i, corner, 0.0);
      }
      for (int c = 0; c < levels; ++c) {
        near.ForEachAtLevel(c, [&](const std::array<int64_t, D>& g) {
          const uint64_t i = near.Index(g);
          if (kept[i]) {
            keep(i, g, HzPredict<D>(g, dims_, false, at));
            return;
          }
          value[i] = HzPredict<D>(g, dims_, true, at);
          if (!Real(g)) return;
          const double d = std::abs(value[i] - FieldAt(g));
          if (t == 0 ? d != 0 : !(d <= t)) {
            force[i] = 1;
            ++failed;
          }
        });
      }
      report->kept_by_check += failed;
      if (failed == 0) break;
    }

    // 3. The blocks, in key order.
    const HzOrder<D> order(k_);
    const int bb = h.block_bits;
    const uint64_t nblocks = (order.size() + (uint64_t{1} << bb) - 1) >> bb;
    const size_t ew = SparseErrorWidth(h.quantization), vw = SparseResidualWidth(h);
    const int finest_first = D * (k_ - 1);
    ZstdCompressor zstd(options_.zstd_level);
    SparsePartCutter cutter(page_bytes);
    const auto kept_at = [&](const std::array<int64_t, D>& q) {
      const uint64_t j = near.Index(q);
      return j != NearGrid<D>::kFar && kept[j] != 0;
    };
    SparseBlock block;
    std::vector<uint8_t> every;  // the bitmap over every vertex
    bool closed = true;
    for (uint64_t b = 0; b < nblocks; ++b) {
      if (options_.progress && (b & 255) == 0) {
        options_.progress(BuildProgress{"blocks", b, nblocks, SecondsSince()});
      }
      if (!MayHoldNear(near, bb, b)) continue;
      block.vertices = 0;
      block.candidates = 0;
      block.kept.clear();
      block.errors.clear();
      block.residuals.clear();
      every.clear();
      const auto set_bit = [](std::vector<uint8_t>& bits, uint32_t n, bool on) {
        if ((n & 7) == 0) bits.push_back(0);
        if (on) bits.back() |= static_cast<uint8_t>(1u << (n & 7));
      };
      ForEachHzVertex<D>(order, b << bb, uint64_t{1} << bb, [&](uint64_t p, const std::array<int64_t, D>& g) {
        const uint64_t i = near.Index(g);
        const bool keep = i != NearGrid<D>::kFar && kept[i];
        set_bit(every, block.vertices++, keep);
        if (!SparseMayBeKept<D>(g, k_, kept_at)) {
          // The kept set is closed under these vertices (step 1).
          if (keep) closed = false;
          return;
        }
        set_bit(block.kept, block.candidates++, keep);
        if (!keep) return;
        const int level = order.LevelAt(p);
        if (level >= 0 && level < finest_first) {
          block.errors.push_back(code[i]);
        }
        block.residuals.push_back(residual[i]);
      });
      if (!closed) {
        return Status::NotSupported(input_.description + ": a kept vertex stands on a dropped one (a SimplexDB bug; please report it)");
      }
      if (block.residuals.empty()) continue;
      // The bitmap over the candidates costs the reader a walk over the
      // block's vertices asking for their ancestors (2 to 3 times the time
      // to decode a block): used when it makes the block at least 1/32
      // smaller (on lossless Perlin noise, where nearly every vertex is
      // kept, using it wherever the bitmap alone got 1/8 smaller left the
      // file the same size and doubled the time of verify).
      std::vector<uint8_t> v;
      {
        SparseBlock plain = block;
        plain.candidates = plain.vertices;
        plain.kept = every;
        SDB_ASSIGN_OR_RETURN(v, EncodeSparseBlock(b, plain, ew, vw, zstd));
      }
      if (block.candidates < block.vertices) {
        SDB_ASSIGN_OR_RETURN(const std::vector<uint8_t> over_candidates, zstd.Compress(block.kept));
        SDB_ASSIGN_OR_RETURN(const std::vector<uint8_t> over_every, zstd.Compress(every));
        if (over_candidates.size() < over_every.size() &&
            (over_every.size() - over_candidates.size()) * 32 >= v.size()) {
          SDB_ASSIGN_OR_RETURN(v, EncodeSparseBlock(b, block, ew, vw, zstd));
        }
      }
      for (size_t from = 0, part = 0, n = 0; from < v.size(); from += n, ++part) {
        n = cutter.Next(v.size() - from);
        const auto key = SparseKey(b, static_cast<uint32_t>(part));
        SDB_RETURN_IF_ERROR(writer.Put(dbi, key, std::span<const uint8_t>(v.data() + from, n), /*append=*/true));
      }
      ++h.blocks;
      h.kept += block.residuals.size();
    }
    return Status::OK();
  }

 private:
  double SecondsSince() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

  // The whole field, as doubles holding the stored values (storage/common/
  // field_loader.h, on every worker); missing values are refused.
  Status ReadField() {
    const LoadFieldOptions load{.stored = type_, .threads = threads_, .start = start_, .progress = options_.progress};
    SDB_ASSIGN_OR_RETURN(LoadedField<double> loaded, LoadField<double>(input_, std::nullopt, load));
    if (loaded.missing) {
      return Status::NotSupported(input_.description +
                                  ": missing values (NaN); the sparse store of format 2 does not "
                                  "take them yet (import a dense store)");
    }
    field_ = std::move(loaded.values);
    fmin_ = loaded.min;
    fmax_ = loaded.max;
    return Status::OK();
  }

  // False when block b lies inside one octave's segment and its cubes all
  // lie past the near vertices of that octave on some axis (nothing kept).
  // Stricter than HzBlockMayHoldVertices: the near limit is at most 2^k.
  bool MayHoldNear(const NearGrid<D>& near, int bb, uint64_t b) const {
    const uint64_t first = b << bb;
    if (first < (uint64_t{1} << D)) return true;
    const int top = 63 - std::countl_zero(first);
    const int o = top / D - 1;
    if (bb > D * (o + 1)) return true;
    const int s = k_ - 1 - o;
    const auto u = internal::FromMorton<D>(first & ((uint64_t{1} << (D * (o + 1))) - 1));
    for (int a = 0; a < D; ++a) {
      if ((u[a] << (s + 1)) > near.limit(s, a)) return false;
    }
    return true;
  }

  bool Real(const std::array<int64_t, D>& g) const {
    for (int a = 0; a < D; ++a) {
      if (g[a] >= dims_[a]) return false;
    }
    return true;
  }
  double FieldAt(const std::array<int64_t, D>& g) const {
    uint64_t i = 0;
    for (int a = D - 1; a >= 0; --a) {
      i = i * static_cast<uint64_t>(dims_[a]) + static_cast<uint64_t>(std::min(g[a], dims_[a] - 1));
    }
    return field_[i];
  }
  std::vector<std::array<int64_t, D>> Corners() const {
    std::vector<std::array<int64_t, D>> out;
    for (uint32_t c = 0; c < (1u << D); ++c) {
      std::array<int64_t, D> g{};
      for (int a = 0; a < D; ++a) g[a] = static_cast<int64_t>(c >> a & 1) << k_;
      out.push_back(g);
    }
    return out;
  }

  const VolumeInfo& input_;
  const SparseBuildOptions& options_;
  Clock::time_point start_;
  std::array<int64_t, D> dims_{};
  int k_ = 1;
  int threads_ = 1;
  VoxelType type_ = VoxelType::kU8;
  BigArray<double> field_;
  double fmin_ = 0, fmax_ = 0;
};

}  // namespace

Result<SparseBuildReport> BuildSparseStore(const VolumeInfo& input, const std::string& out_path,
                                           const SparseBuildOptions& options) {
  const Clock::time_point start = Clock::now();
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance)) {
    return Status::InvalidArgument("tolerance " + std::to_string(options.tolerance) +
                                   ": expected a finite number >= 0");
  }
  const int dimension = input.dimension;
  if (dimension != 3 && dimension != 4) {
    return Status::InvalidArgument(input.description + ": a " + std::to_string(dimension) +
                                   "D volume; the sparse store takes 3D (HT) and 4D (HP) ones");
  }
  if (options.block_bits != 0 && (options.block_bits < dimension || options.block_bits > 24)) {
    return Status::InvalidArgument("block bits " + std::to_string(options.block_bits) + ": expected " +
                                   std::to_string(dimension) + " to 24");
  }
  SDB_RETURN_IF_ERROR(PrepareOutput(out_path));
  TemporaryFile temp(out_path);
  SparseBuildReport report;
  {
    lmdb::Env::Options env_options;
    env_options.read_only = false;
    env_options.name = out_path;
    env_options.map_bytes = uint64_t{64} << 20;
    SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> env, lmdb::Env::Open(temp.path(), env_options));
    // One unnamed database: named ones would cost two pages more, a lot
    // for a small store.
    MDB_dbi dbi;
    {
      SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/true));
      SDB_ASSIGN_OR_RETURN(dbi, txn.OpenDb(nullptr, false));
      SDB_RETURN_IF_ERROR(txn.Commit());
    }
    // Blocks and header in one transaction unless the store is larger than
    // the writer's batch: no page copied and freed by a later one.
    lmdb::BatchWriter writer(*env);
    if (dimension == 3) {
      Builder<3> b(input, options, start);
      SDB_RETURN_IF_ERROR(b.Run(writer, dbi, env->page_bytes(), &report));
    } else {
      Builder<4> b(input, options, start);
      SDB_RETURN_IF_ERROR(b.Run(writer, dbi, env->page_bytes(), &report));
    }
    SDB_RETURN_IF_ERROR(writer.Put(dbi, kSparseHeaderKey, EncodeSparseHeader(report.header), /*append=*/true));
    SDB_RETURN_IF_ERROR(writer.Flush());
    SDB_RETURN_IF_ERROR(env->Sync());
  }
  SDB_RETURN_IF_ERROR(temp.Commit());
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  std::error_code size_error;
  report.file_bytes = std::filesystem::file_size(out_path, size_error);
  return report;
}

}  // namespace simplexdb
