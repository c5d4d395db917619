// The dense builder's one pipeline (storage/dense/dense_builder.h), which
// PlanWindows and BuildWindowed run (dense_windowed_build.cc).
#pragma once

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <type_traits>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/common/field_loader.h"
#include "storage/common/parallel_run.h"
#include "storage/dense/dense_build_internal.h"
#include "storage/dense/dense_writer.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/slab_ranks_internal.h"
#include "storage/dense/sub_lattice_internal.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/field_values.h"  // CheckFieldRange
#include "storage/error/mask.h"  // StoredVoxelType
#include "storage/error/quantize.h"
#include "util/big_array.h"

namespace simplexdb::dense_build {

// The build: the field read a slab of T planes of the last axis at a time
// (T a power of two), with a halo of 2^S planes on each side, S =
// kLocalScales, so that memory holds the window, not the grid. Per slab:
// the local scales' diamonds of the slab's vertices (a table per scale
// holding one chunk of planes, written when complete), the scanned scales'
// errors over the slab's points (maxima kept per vertex of the domain:
// few), each grid brick's largest finest error, and the bricks of lattices
// 0..2; every 8th point is kept for the coarser lattices' bricks. Then the
// scanned scales' blocks and the coarse bricks.
//
// With one slab (T past the last vertex plane: the field fits, or the grid
// is too small to cut), the window is the whole field, read once; the
// range and the corners come from it, and every block then every brick is
// written at the end, in index order. With several, a first pass reads
// every plane once for the range (the quantum depends on it), the checks
// and the corner lattice (the points at multiples of 2^S and each axis's
// last index: the corners of every scanned simplex, clamped), and a slab's
// items go to the writer's spool as soon as they are complete; the writer
// puts them in index order at the end (the same bytes as one window's).
//
// Ranks of a group (DenseBuildOptions::group) each build a run of slabs
// (SlabRanks), share what crosses them, and the writer makes one file.
//
// The errors are the same whatever T: a local scale's diamond reads only
// its window; a scanned one is the maximum over the slabs of its parts.
template <int D, class V>
class WindowedBuild {
 public:
  static constexpr int L = D - 1;  // the axis the slabs cut
  static constexpr int S = DiamondErrors<D, V>::kLocalScales;
  static constexpr int kCoarseShift = 3;  // lattices >= 3 from a copy of every 8th point

  WindowedBuild(const VolumeInfo& input, const std::string& out, const DenseBuildOptions& options,
                Clock::time_point start, int k, int threads, int64_t slab)
      : input_(input), out_(out), options_(options), start_(start), k_(k), threads_(threads),
        side_(int64_t{1} << k), grid_(D, input.dims, k, DenseDefaultBrickBits(D)), order_(k),
        stored_(StoredVoxelType(input, options.mask.has_value())) {
    n_ = 1;
    for (int a = 0; a < D; ++a) {
      dims_[a] = input.dims[a];
      stride_[a] = static_cast<int64_t>(n_);
      n_ *= input.dims[a];
    }
    plane_ = n_ / static_cast<uint64_t>(dims_[L]);
    slab_ = slab;
    halo_ = int64_t{1} << S;
    last_vertex_plane_ = std::min(side_, dims_[L] - 1 + halo_);
    slabs_ = last_vertex_plane_ / slab_ + 1;
    ranks_ = SlabRanks(options.group, slabs_, slab_, last_vertex_plane_, dims_[L]);
    first_slab_ = ranks_.first_slab();
    end_slab_ = ranks_.end_slab();
    window_planes_ = std::min(dims_[L], slab_ + 2 * halo_);
    const int64_t zcells = int64_t{1} << (options.block_bits / D);
    for (int s = 1; s < std::min(S, k); ++s) {
      Local& t = local_[static_cast<size_t>(s)];
      const int64_t h = int64_t{1} << s;
      t.chunk = std::max<int64_t>(zcells << (s + 1), slab_);
      uint64_t size = 1;
      for (int a = 0; a < D; ++a) {
        const int64_t vertices = std::min(side_, dims_[a] - 1 + 2 * h) / h + 1;
        t.extent[a] = a == L ? std::min(t.chunk / h, vertices) : vertices;
        t.stride[a] = size;
        size *= static_cast<uint64_t>(t.extent[a]);
      }
      t.size = size;
    }
    for (int s = S; s < k; ++s) {
      Scanned& t = scanned_[static_cast<size_t>(s)];
      uint64_t size = 1;
      for (int a = 0; a < D; ++a) {
        t.stride[a] = size;
        size *= static_cast<uint64_t>((side_ >> s) + 1);
      }
      t.size = size;
    }
    if (k > S) corners_ = SubLattice<D, double>(dims_, S, true);  // only scanned scales read corners
    if (!OneWindow()) coarse_ = SubLattice<D, V>(dims_, kCoarseShift, false);  // else bricks from the window
  }

  bool OneWindow() const { return slabs_ == 1; }
  int windows() const { return static_cast<int>(slabs_); }
  int64_t window_planes() const { return window_planes_; }

  // The memory the build takes, for the bound: the window, the tables (with
  // missing values, the scanned diamonds' availability), the readers' buffers
  // (2^20 doubles or a plane per worker; twice with a mask), the writer's.
  uint64_t Bytes(bool missing = false) const {
    uint64_t bytes = static_cast<uint64_t>(window_planes_) * plane_ * sizeof(V);
    for (int s = 1; s < S; ++s) {
      // With several ranks, a chunk longer than a slab may be kept at both
      // ends of this rank's slabs.
      const Local& t = local_[static_cast<size_t>(s)];
      bytes += t.size * sizeof(float) * (ranks_.ranks() > 1 && t.chunk > slab_ ? 3 : 1);
    }
    for (int s = S; s < k_; ++s) {
      bytes += scanned_[static_cast<size_t>(s)].size * (sizeof(float) + (missing ? sizeof(DiamondAvailability) : 0));
    }
    bytes += corners_.size() * sizeof(double) + coarse_.size() * sizeof(V);
    bytes += grid_.Count(0) * sizeof(double);  // finest maxima
    const uint64_t buffer = OneWindow() ? std::min<uint64_t>(n_, uint64_t{1} << 20) : plane_;
    bytes += uint64_t(threads_) * buffer * sizeof(double) * (options_.mask ? 2 : 1);
    bytes += uint64_t(threads_) * (uint64_t{1} << options_.block_bits) * 40;  // writer
    // The writer's tables; with several windows ours are freed before its
    // Finish (FreeTables).
    DenseHeader params = ParamsFor(D, input_, options_, stored_, k_, 0, 1);
    params.flags = missing ? kDenseFinestStored : 0;
    const DenseStoreWriter::Memory w = DenseStoreWriter::MemoryFor(params, !OneWindow());
    return w.tables + (OneWindow() ? bytes + w.finish : std::max(bytes, w.finish));
  }

  // Each step's outcome becomes every rank's (Together) before the next
  // exchanges anything, so a failure anywhere stops all at the same place.
  Result<DenseBuildReport> Run() {
    SDB_RETURN_IF_ERROR(ranks_.Together(OneWindow() ? LoadWholeField() : ReadRangeAndCorners()));
    if (ranks_.group() != nullptr) SDB_RETURN_IF_ERROR(ShareRangeAndCorners());
    SDB_RETURN_IF_ERROR(ranks_.Together(Prepare()));
    Status slabs = Status::OK();
    for (int64_t i = first_slab_; i < end_slab_ && slabs.ok(); ++i) {
      slabs = Slab(i * slab_, i + 1 == slabs_);
      if (options_.progress && !OneWindow()) {
        options_.progress({"slabs", static_cast<uint64_t>(i + 1 - first_slab_),
                           static_cast<uint64_t>(end_slab_ - first_slab_),
                           std::chrono::duration<double>(Clock::now() - start_).count()});
      }
    }
    SDB_RETURN_IF_ERROR(ranks_.Together(slabs));
    if (ranks_.group() != nullptr) SDB_RETURN_IF_ERROR(ShareAfterSlabs());
    SDB_RETURN_IF_ERROR(ranks_.Together(WriteLast()));
    if (!OneWindow()) FreeTables();  // Finish's records take their place (Bytes)
    SDB_ASSIGN_OR_RETURN(const DenseHeader header, writer_->Finish());
    return DenseBuildReport{header, std::chrono::duration<double>(Clock::now() - start_).count(), n_,
                            OneWindow() ? "diamonds" : "streamed", static_cast<int>(slabs_),
                            window_planes_, ranks_.ranks(), static_cast<int>(end_slab_ - first_slab_),
                            writer_->candidate_blocks().size()};
  }

 private:
  // The checks the range allows, the tables, the writer.
  Status Prepare() {
    if (missing_ && !options_.mask) {
      SDB_RETURN_IF_ERROR(CheckBlockBitmap(D, input_.dims, k_, options_, true, out_, input_.description));
    }
    if (missing_ && Bytes(true) > options_.memory_bytes) {
      return Status::ResourceExhausted(out_ + ": the volume has missing values, whose availability raises the "
                                       "build's need from " + MiB(Bytes()) + " to " + MiB(Bytes(true)) +
                                       ", more than the memory bound of " + MiB(options_.memory_bytes) +
                                       " (--memory-mb)");
    }
    for (Local& t : local_) t.table = BigArray<float>(t.size);  // zeros (size 0 past the local scales)
    for (int s = S; s < k_; ++s) {
      Scanned& t = scanned_[static_cast<size_t>(s)];
      t.table.assign(t.size, 0.0f);
      if (missing_) t.availability.assign(t.size, DiamondAvailability{});
    }
    if (!missing_) finest_max_.assign(grid_.Count(0), 0.0);
    if (!OneWindow()) {
      coarse_.Allocate();
      window_ = BigArray<V>(static_cast<size_t>(window_planes_) * plane_);
    }

    // With missing values every diamond is scanned and the finest octave's
    // errors are stored (DiamondErrors).
    DenseHeader params = ParamsFor(D, input_, options_, stored_, k_, fmin_, fmax_);
    if (missing_) params.flags = kDenseFinestStored;
    DenseWriteOptions write = WriteOptionsFor(options_, threads_);
    if (OneWindow()) write.progress = options_.progress;  // one run each of blocks and bricks
    // Several windows make blocks and bricks out of the store's order.
    write.spool = !OneWindow();
    write.group = ranks_.group();
    SDB_ASSIGN_OR_RETURN(writer_, DenseStoreWriter::Create(out_, params, write));
    AssignBlocks();

    diamonds_ = std::make_unique<DiamondErrors<D, V>>(window_.data(), dims_, k_, !IsFloatType(stored_),
                                                       fmax_ - fmin_, threads_, true, missing_);
    return Status::OK();
  }

  // What is written once every slab is done: with one window, every block
  // then every brick, each in index order; with several (by rank 0 of a
  // group), the scanned scales' blocks (and those spanning several
  // octaves: their finest positions are past the stored ones, CanCut),
  // then the coarse lattices' bricks.
  Status WriteLast() {
    if (OneWindow()) {
      SDB_RETURN_IF_ERROR(writer_->WriteBlocks(Iota(writer_->candidate_blocks().size()), Fill(0)));
      return writer_->WriteBricks(Iota(grid_.bricks()), WindowHeld(), FinestMax());
    }
    if (ranks_.rank() != 0) return Status::OK();
    SDB_RETURN_IF_ERROR(writer_->WriteBlocks(scanned_blocks_, Fill(last_slab_first_, S)));
    std::vector<uint64_t> coarse_bricks;
    for (int s = kCoarseShift; s < grid_.lattices(); ++s) {
      for (uint64_t b = grid_.FirstBrick(s); b < grid_.FirstBrick(s) + grid_.Count(s); ++b) coarse_bricks.push_back(b);
    }
    HeldField<V> held{coarse_.data(), {}, 0, kCoarseShift};
    for (int a = 0; a < D; ++a) held.stride[a] = static_cast<int64_t>(coarse_.stride(a));
    return writer_->WriteBricks(coarse_bricks, held, FinestMax());
  }

  // A group's range, whether values are missing, and the corner lattice.
  Status ShareRangeAndCorners() {
    SDB_RETURN_IF_ERROR(ranks_.ShareRange(fmin_, fmax_, present_, missing_));
    SDB_RETURN_IF_ERROR(ranks_.SharePlanes(corners_));
    return ranks_.Together(CheckFieldRange(input_, fmin_, fmax_));
  }
  // After the slabs: the scanned scales' maxima over every rank's, the
  // coarse lattices' points, and the local tables' chunks that several
  // ranks built parts of, each combined and written by one rank
  // (SlabRanks::CombineSplit; a rank that failed writes no more).
  Status ShareAfterSlabs() {
    static_assert(sizeof(DiamondAvailability) == 2 * sizeof(uint64_t));
    ProcessGroup& group = *ranks_.group();
    for (int s = S; s < k_; ++s) {
      Scanned& t = scanned_[static_cast<size_t>(s)];
      SDB_RETURN_IF_ERROR(group.Max(std::span<float>(t.table)));
      uint64_t* words = reinterpret_cast<uint64_t*>(t.availability.data());
      if (missing_) SDB_RETURN_IF_ERROR(group.Or({words, 2 * t.availability.size()}));
    }
    SDB_RETURN_IF_ERROR(ranks_.SharePlanes(coarse_));
    Status status;
    for (int s = 1; s < S; ++s) {
      Local& t = local_[static_cast<size_t>(s)];
      const auto part_of = [&](int64_t c) -> const std::vector<float>* {
        const auto part = split_parts_.find({s, static_cast<uint64_t>(c)});
        return part != split_parts_.end() ? &part->second : nullptr;
      };
      const auto write = [&](int64_t c) {
        const uint64_t i = static_cast<uint64_t>(c);
        return status.ok() && i < t.blocks.size() ? writer_->WriteBlocks(t.blocks[i], Fill(c * t.chunk)) : Status::OK();
      };
      const Status combined = ranks_.CombineSplit(t.chunk, {t.table.data(), t.table.size()}, part_of, write);
      if (status.ok()) status = combined;
    }
    return ranks_.Together(status);
  }

  using Local = LocalTable<D>;
  using Scanned = ScannedTable<D>;

  // Several windows: what the slabs and WriteLast needed, freed for Finish.
  void FreeTables() {
    diamonds_.reset();  // it points into the window
    planes_.reset();
    window_ = BigArray<V>();
    for (Local& t : local_) t.table = BigArray<float>();
    for (Scanned& t : scanned_) t.Release();
    corners_.Release();
    coarse_.Release();
    std::vector<double>().swap(finest_max_);
  }

  static std::vector<uint64_t> Iota(uint64_t n) {  // 0, 1, ..., n - 1
    std::vector<uint64_t> v(n);
    for (uint64_t i = 0; i < n; ++i) v[i] = i;
    return v;
  }
  // The bricks' largest finest errors for the writer; null when they are
  // stored (missing values).
  const double* FinestMax() const { return missing_ ? nullptr : finest_max_.data(); }
  // The window as the writer reads bricks from it.
  HeldField<V> WindowHeld() const {
    HeldField<V> held{window_.data(), {}, window_first_, 0};
    held.stride[0] = 1;
    for (int a = 1; a < 4; ++a) held.stride[a] = a < D ? stride_[a] : 0;
    return held;
  }

  uint64_t ScannedIndex(const std::array<int64_t, D>& g, int s) const {
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) i += static_cast<uint64_t>(g[a] >> s) * scanned_[static_cast<size_t>(s)].stride[a];
    return i;
  }
  // The local table's entry of g (scale s) in the chunk from `chunk_first`;
  // null past the table (a vertex whose diamond has no real point).
  float* LocalSlot(const std::array<int64_t, D>& g, int s, int64_t chunk_first) {
    Local& t = local_[static_cast<size_t>(s)];
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) {
      const int64_t c = ((a == L ? g[a] - chunk_first : g[a]) >> s);
      if (c < 0 || c >= t.extent[a]) return nullptr;
      i += static_cast<uint64_t>(c) * t.stride[a];
    }
    return &t.table[i];
  }
  // The first plane of the chunk of local scale s holding plane z.
  int64_t ChunkFirst(int s, int64_t z) const {
    const int64_t chunk = local_[static_cast<size_t>(s)].chunk;
    return z / chunk * chunk;
  }

  // The writer's fill for blocks of the octaves the tables hold now (the
  // slab from plane z0 is the window), scales below `min_scale` left 0: a
  // finest vertex's error computed from the window (stored finest octave),
  // a local scale's from the chunk holding z0, a scanned scale's from its
  // maxima (rounded up as a local one's, also where the field range stands
  // for a partly missing diamond).
  DenseFill Fill(int64_t z0, int min_scale = 0) {
    // HZ order is not the tables': the positions' entries are found a batch
    // at a time and asked for before any is read.
    return [this, z0, min_scale](int, uint64_t first, size_t count, double* errors) -> Status {
      constexpr size_t kBatch = 64;
      std::array<std::array<int64_t, D>, kBatch> g{};
      std::array<int, kBatch> scale{};
      std::array<const float*, kBatch> entry{};
      for (size_t base = 0; base < count; base += kBatch) {
        const size_t batch = std::min(kBatch, count - base);
        for (size_t i = 0; i < batch; ++i) {
          scale[i] = -1;
          entry[i] = nullptr;
          if (!order_.Decode(first + base + i, g[i])) continue;
          const int level = order_.Level(g[i]);
          if (level < 0) continue;
          const int s = k_ - 1 - level / D;
          if (s < min_scale) continue;
          scale[i] = s;
          if (s == 0) continue;
          entry[i] = s < S ? LocalSlot(g[i], s, ChunkFirst(s, z0))
                           : &scanned_[static_cast<size_t>(s)].table[ScannedIndex(g[i], s)];
          if (entry[i] != nullptr) __builtin_prefetch(entry[i]);
        }
        for (size_t i = 0; i < batch; ++i) {
          const int s = scale[i];
          double& e = errors[base + i];
          if (s == 0) {
            e = diamonds_->At(g[i], first + base + i);
          } else if (entry[i] != nullptr) {
            e = *entry[i];
            const Scanned& t = scanned_[static_cast<size_t>(s)];
            if (s >= S && missing_) e = RoundUpToFloat(diamonds_->MergedError(e, t.availability[ScannedIndex(g[i], s)]));
          }
        }
      }
      return Status::OK();
    };
  }

  // One window: the whole field read once (as the store keeps it), its
  // range and whether values are missing, and the corner lattice from it.
  Status LoadWholeField() {
    const LoadFieldOptions load{.stored = stored_, .threads = threads_, .start = start_, .progress = options_.progress};
    SDB_ASSIGN_OR_RETURN(LoadedField<V> loaded, LoadField<V>(input_, options_.mask, load));
    window_ = std::move(loaded.values);
    window_first_ = 0;
    window_end_ = dims_[L];
    fmin_ = loaded.min;
    fmax_ = loaded.max;
    missing_ = loaded.missing;
    corners_.Allocate();
    for (int64_t z = 0; corners_.size() > 0 && z < dims_[L]; ++z) {
      if (corners_.HasPlane(z)) corners_.SetPlane(z, window_.data() + static_cast<size_t>(z) * plane_, stride_);
    }
    return Status::OK();
  }

  // Several windows, pass 1: every plane (of this rank's slabs) once, on
  // every worker, for the range, the checks and the corner lattice.
  Status ReadRangeAndCorners() {
    corners_.Allocate();
    const auto [lo, hi] = ranks_.RealPlanesOf(ranks_.rank());
    const LoadFieldOptions scan{.stored = stored_, .threads = threads_, .start = start_, .progress = options_.progress,
                                .first_plane = lo, .end_plane = hi};
    SDB_ASSIGN_OR_RETURN(const FieldRange range,
                         ScanPlanes(input_, options_.mask, scan, [&](int64_t z, const double* values) {
                           if (corners_.HasPlane(z)) corners_.SetPlane(z, values, stride_);
                         }));
    fmin_ = range.min;
    fmax_ = range.max;
    missing_ = range.missing;
    present_ = range.present;
    return Status::OK();
  }

  // With several slabs, each candidate block to the run that writes it: a
  // local scale's to its chunk, a stored finest one to its slab, the
  // others' to the end. (One window writes them all at the end.)
  void AssignBlocks() {
    if (OneWindow()) return;
    const auto& candidates = writer_->candidate_blocks();
    for (uint64_t i = 0; i < candidates.size(); ++i) {
      const DenseStoreWriter::BlockSpan span = writer_->SpanOf(candidates[i]);
      if (span.scale >= 1 && span.scale < S) {
        Local& t = local_[static_cast<size_t>(span.scale)];
        const uint64_t chunk = static_cast<uint64_t>(span.lo[L] / t.chunk);
        if (t.blocks.size() <= chunk) t.blocks.resize(chunk + 1);
        t.blocks[chunk].push_back(i);
      } else if (span.scale != 0) {
        scanned_blocks_.push_back(i);
      } else if (missing_) {
        // Stored finest blocks, written by the slab holding their planes
        // (a block's span is shorter than a slab and aligned to it).
        const uint64_t slab = static_cast<uint64_t>(span.lo[L] / slab_);
        assert(span.hi[L] < static_cast<int64_t>(slab + 1) * slab_);
        if (finest_blocks_.size() <= slab) finest_blocks_.resize(slab + 1);
        finest_blocks_[slab].push_back(i);
      }
      // Otherwise finest (scale 0) blocks are not stored: the bricks record
      // their maxima.
    }
  }

  // Reads the real planes [lo, hi) into the window (planes from window_first_).
  // The reader stays open from slab to slab (a gzip file is read by one
  // worker, which would inflate everything before a plane if opened anew).
  Status ReadPlanes(int64_t lo, int64_t hi) {
    if (planes_ == nullptr) planes_ = std::make_unique<PlaneReader>(input_, options_.mask, threads_);
    return planes_->Read(lo, hi, "field", start_, {}, [&](int, int64_t z, double* values) -> Status {
      V* to = window_.data() + static_cast<size_t>(z - window_first_) * plane_;
      for (uint64_t j = 0; j < plane_; ++j) {
        const double v = stored_ == VoxelType::kF32 ? static_cast<float>(values[j]) : values[j];
        // NaN (missing) only in float fields: a masked integer volume is stored as float32.
        assert(std::is_floating_point_v<V> || !std::isnan(v));
        to[j] = static_cast<V>(v);
      }
      // Every 8th point of every 8th plane, for the coarse lattices' bricks.
      if (coarse_.HasPlane(z)) coarse_.SetPlane(z, to, stride_);
      return Status::OK();
    });
  }

  // The window for the slab [z0, z0 + slab_): real planes [z0 - halo, z1 +
  // halo), keeping what the last one read.
  Status MoveWindow(int64_t z0) {
    if (OneWindow()) return Status::OK();  // the whole field, read already
    const int64_t lo = std::max<int64_t>(0, z0 - halo_), hi = std::min(dims_[L], z0 + slab_ + halo_);
    if (window_first_ >= 0 && lo < window_end_ && lo >= window_first_) {
      std::memmove(window_.data(), window_.data() + static_cast<size_t>(lo - window_first_) * plane_,
                   static_cast<size_t>(window_end_ - lo) * plane_ * sizeof(V));
      const int64_t kept_end = window_end_;
      window_first_ = lo;
      window_end_ = hi;
      SDB_RETURN_IF_ERROR(ReadPlanes(kept_end, hi));
    } else {
      window_first_ = lo;
      window_end_ = hi;
      SDB_RETURN_IF_ERROR(ReadPlanes(lo, hi));
    }
    diamonds_->SetWindow(window_.data(), window_first_);
    return Status::OK();
  }

  // Slab [z0, z0 + slab_): its window, its errors, and (several slabs) its
  // bricks and the chunks it completes.
  Status Slab(int64_t z0, bool last) {
    const int64_t z1 = z0 + slab_;
    SDB_RETURN_IF_ERROR(MoveWindow(z0));
    last_slab_first_ = z0;

    // Work items, the heavy ones first: scanned rows, local rows, finest boxes.
    struct Item {
      int kind;   // 0 local row, 1 scanned row, 2 finest box
      int s;
      int64_t j;  // row: last coordinate j * 2^s; box: the brick
    };
    std::vector<Item> items;
    const int64_t real_hi = std::min(z1, dims_[L]) - 1;  // the slab's real planes: [z0, real_hi]
    if (z0 <= real_hi) {
      for (int s = k_ - 1; s >= S; --s) {
        const int64_t h = int64_t{1} << s;
        for (int64_t z = std::max<int64_t>(0, (z0 - 2 * h + h - 1) / h * h); z <= std::min(side_, real_hi + 2 * h); z += h) {
          items.push_back({1, s, z / h});
        }
      }
    }
    for (int s = std::min(S, k_) - 1; s >= 1; --s) {
      const int64_t h = int64_t{1} << s;
      for (int64_t z = (z0 + h - 1) / h * h; z < z1 && z <= std::min(side_, dims_[L] - 1 + 2 * h); z += h) {
        items.push_back({0, s, z / h});
      }
    }
    const uint64_t first0 = grid_.FirstBrick(0);
    std::vector<uint64_t> bricks;
    for (int s = 0; s < kCoarseShift && s < grid_.lattices(); ++s) {
      for (uint64_t b = grid_.FirstBrick(s); b < grid_.FirstBrick(s) + grid_.Count(s); ++b) {
        const int64_t first = grid_.Place(b).first[L];
        if (first < z0 || first >= z1) continue;
        bricks.push_back(b);
        if (s == 0 && !missing_) items.push_back({2, 0, static_cast<int64_t>(b)});
      }
    }
    const auto corner = [this](const std::array<int64_t, D>& c) { return corners_.At(c); };
    SDB_RETURN_IF_ERROR(RunParallel(items.size(), threads_, "errors", start_,
                                    OneWindow() ? options_.progress : nullptr, [&](int, uint64_t i) -> Status {
      const Item it = items[i];
      if (it.kind == 0) {
        const int64_t cf = ChunkFirst(it.s, z0);
        diamonds_->ComputeRowInto(it.s, it.j, [&](const std::array<int64_t, D>& g, double e) {
          if (float* slot = LocalSlot(g, it.s, cf)) *slot = RoundUpToFloat(e);
        });
      } else if (it.kind == 1) {
        diamonds_->ComputeRowPartInto(it.s, it.j, z0, real_hi, corner,
                                      [&](const std::array<int64_t, D>& g, double e,
                                          const DiamondAvailability& a) {
          Scanned& t = scanned_[static_cast<size_t>(it.s)];
          const uint64_t at = ScannedIndex(g, it.s);
          t.table[at] = std::max(t.table[at], RoundUpToFloat(e));
          if (missing_) t.availability[at].Merge(a);
        });
      } else {
        const BrickGrid::Box box = grid_.FinestBox(static_cast<uint64_t>(it.j));
        std::array<int64_t, D> first{}, extent{};
        for (int a = 0; a < D; ++a) {
          first[a] = box.first[a];
          extent[a] = box.extent[a];
        }
        finest_max_[static_cast<uint64_t>(it.j) - first0] = diamonds_->FinestBoxMax(first, extent);
      }
      return Status::OK();
    }));
    if (OneWindow()) return Status::OK();  // everything is written at the end

    SDB_RETURN_IF_ERROR(writer_->WriteBricks(bricks, WindowHeld(), FinestMax()));
    // Stored finest blocks of this slab: computed from the window.
    const uint64_t slab = static_cast<uint64_t>(z0 / slab_);
    if (slab < finest_blocks_.size()) SDB_RETURN_IF_ERROR(writer_->WriteBlocks(finest_blocks_[slab], Fill(z0)));
    // Chunks this slab completes: their blocks, then a clean table. A
    // chunk another rank builds part of (it began before this rank's
    // slabs, or goes on past them) is kept for CombineSplitChunks.
    const bool rank_end = static_cast<int64_t>(slab) + 1 == end_slab_;
    for (int s = 1; s < S; ++s) {
      Local& t = local_[static_cast<size_t>(s)];
      const bool complete = last || z1 % t.chunk == 0;
      if (!complete && !rank_end) continue;
      const uint64_t chunk = static_cast<uint64_t>(ChunkFirst(s, z0) / t.chunk);
      if (!complete || ChunkFirst(s, z0) < first_slab_ * slab_) {
        split_parts_[{s, chunk}].assign(t.table.data(), t.table.data() + t.table.size());
      } else if (chunk < t.blocks.size()) {
        SDB_RETURN_IF_ERROR(writer_->WriteBlocks(t.blocks[chunk], Fill(z0)));
      }
      // (Chunks past the last slab hold no vertex with data: their
      // candidates are never written, so not stored.)
      std::fill(t.table.data(), t.table.data() + t.table.size(), 0.0f);
    }
    return Status::OK();
  }

  const VolumeInfo& input_;
  std::string out_;
  DenseBuildOptions options_;
  Clock::time_point start_;
  int k_, threads_;
  int64_t side_;
  BrickGrid grid_;
  HzOrder<D> order_;
  VoxelType stored_;
  std::array<int64_t, D> dims_{}, stride_{};  // the field's, x fastest
  uint64_t n_ = 1, plane_ = 1;
  int64_t slab_ = 0, halo_ = 0, last_vertex_plane_ = 0, slabs_ = 1, window_planes_ = 0;
  int64_t last_slab_first_ = 0;
  std::array<Local, S> local_{};
  std::array<Scanned, kCoordBits<D>> scanned_{};
  SubLattice<D, double> corners_;  // empty without scanned scales
  SubLattice<D, V> coarse_;         // empty with one window
  BigArray<V> window_;
  std::vector<double> finest_max_;
  std::vector<uint64_t> scanned_blocks_;
  std::vector<std::vector<uint64_t>> finest_blocks_;  // by slab (missing values)
  bool missing_ = false;  // the field has missing values (NaN)
  bool present_ = false;  // some value is not missing (pass 1, this rank's planes)
  SlabRanks ranks_{nullptr, 1, 1, 0, 1};  // who builds which slabs
  // Chunks of local tables (scale, chunk) another rank builds part of.
  std::map<std::pair<int, uint64_t>, std::vector<float>> split_parts_;
  int64_t first_slab_ = 0, end_slab_ = 1;  // this rank's slabs
  double fmin_ = std::numeric_limits<double>::infinity(), fmax_ = -fmin_;
  int64_t window_first_ = -1, window_end_ = -1;
  std::unique_ptr<DenseStoreWriter> writer_;
  std::unique_ptr<DiamondErrors<D, V>> diamonds_;
  std::unique_ptr<PlaneReader> planes_;  // the slabs' reader
};

}  // namespace simplexdb::dense_build
