#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <type_traits>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/common/field_loader.h"
#include "storage/common/parallel_run.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/dense_build_internal.h"
#include "storage/dense/dense_writer.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"  // StoredVoxelType
#include "storage/error/quantize.h"

namespace simplexdb::dense_build {
namespace {

// The streamed build: the field read a window of planes of the last axis
// at a time, so that memory holds the window, not the grid. Pass 1 reads
// every plane once for the range (the quantum depends on it), the checks
// and the corner lattice (the points at multiples of 2^S, S =
// kLocalScales, and each axis's last index: the corners of every scanned
// simplex, clamped). Pass 2 takes slabs of T planes with a halo of 2^S on
// each side: the local scales' diamonds of the slab's vertices (a table
// per scale holding one run of blocks along the last axis, written when
// complete), the scanned scales' errors over the slab's points (maxima
// kept per vertex, whole: few), each grid brick's largest finest error,
// and the bricks of lattices 0..2; every 8th point is kept for the coarser
// lattices' bricks. Then the scanned scales' blocks and the coarse bricks.
// Same errors as BuildDirect: every diamond of a local scale reads only
// its window; a scanned one is the maximum over the slabs of its parts.
template <int D, class V>
class StreamedBuild {
 public:
  static constexpr int L = D - 1;  // the axis the slabs cut
  static constexpr int S = DiamondErrors<D, V>::kLocalScales;
  static constexpr int kCoarseShift = 3;  // lattices >= 3 from a copy of every 8th point

  // Whether a grid of domain bits k with blocks of block_bits can be
  // streamed: every block spanning several octaves holds scanned scales.
  static bool Applies(int k, int block_bits) {
    return k > S + 1 && k + 1 - (block_bits + D - 1) / D >= S;
  }

  StreamedBuild(const VolumeInfo& input, const std::string& out, const DenseBuildOptions& options,
                Clock::time_point start, int k, int threads)
      : input_(input), out_(out), options_(options), start_(start), k_(k), threads_(threads),
        side_(int64_t{1} << k), grid_(D, input.dims, k, DenseDefaultBrickBits(D)), order_(k) {
    n_ = 1;
    for (int a = 0; a < D; ++a) {
      dims_[a] = input.dims[a];
      stride_[a] = static_cast<int64_t>(n_);
      n_ *= input.dims[a];
    }
    plane_ = n_ / static_cast<uint64_t>(dims_[L]);
    const int64_t zcells = int64_t{1} << (options.block_bits / D);
    slab_ = std::max<int64_t>(zcells << 2, int64_t{4} << DenseDefaultBrickBits(D));
    halo_ = int64_t{1} << S;
    last_vertex_plane_ = std::min(side_, dims_[L] - 1 + halo_);
    for (int s = 1; s < S; ++s) {
      Local& t = local_[static_cast<size_t>(s)];
      const int64_t h = int64_t{1} << s;
      t.chunk = std::max<int64_t>(zcells << (s + 1), slab_);
      uint64_t size = 1;
      for (int a = 0; a < D; ++a) {
        t.extent[a] = a == L ? t.chunk / h : std::min(side_, dims_[a] - 1 + 2 * h) / h + 1;
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
    // The corner lattice: multiples of 2^S and the last index, per axis.
    uint64_t corners = 1;
    for (int a = 0; a < D; ++a) {
      corner_count_[a] = (dims_[a] - 1) / halo_ + 1 + ((dims_[a] - 1) % halo_ != 0 ? 1 : 0);
      corner_stride_[a] = corners;
      corners *= static_cast<uint64_t>(corner_count_[a]);
    }
    corner_size_ = corners;
    uint64_t coarse = 1;
    for (int a = 0; a < D; ++a) {
      coarse_count_[a] = ((dims_[a] - 1) >> kCoarseShift) + 1;
      coarse_stride_[a] = static_cast<int64_t>(coarse);
      coarse *= static_cast<uint64_t>(coarse_count_[a]);
    }
    coarse_size_ = coarse;
  }

  // The memory the build takes, for the bound.
  uint64_t Bytes() const {
    uint64_t bytes = (static_cast<uint64_t>(slab_ + 2 * halo_) * plane_) * sizeof(V);  // window
    for (int s = 1; s < S; ++s) bytes += local_[static_cast<size_t>(s)].size * sizeof(float);
    for (int s = S; s < k_; ++s) bytes += scanned_[static_cast<size_t>(s)].size * sizeof(float);
    bytes += corner_size_ * sizeof(double) + coarse_size_ * sizeof(V);
    bytes += grid_.Count(0) * sizeof(double);                        // finest maxima
    bytes += uint64_t(threads_) * plane_ * sizeof(double) * (options_.mask ? 2 : 1);  // readers' planes
    bytes += uint64_t(threads_) * (uint64_t{1} << options_.block_bits) * 40;  // writer
    return bytes;
  }

  // The memory the availability of the scanned scales' diamonds takes
  // (with missing values).
  uint64_t AvailabilityBytes() const {
    uint64_t bytes = 0;
    for (int s = S; s < k_; ++s) bytes += scanned_[static_cast<size_t>(s)].size * sizeof(DiamondAvailability);
    return bytes;
  }

  Result<DenseBuildReport> Run() {
    SDB_RETURN_IF_ERROR(ReadRangeAndCorners());
    if (missing_ && !options_.mask) {
      SDB_RETURN_IF_ERROR(CheckBlockBitmap(D, input_.dims, k_, options_, true, out_, input_.description));
    }
    if (missing_ && Bytes() + AvailabilityBytes() > options_.memory_bytes) {
      return Status::ResourceExhausted(
          out_ + ": the volume has missing values, whose availability needs " +
          MiB(AvailabilityBytes()) + " beside the window's " + MiB(Bytes()) +
          ", more than the memory bound of " + MiB(options_.memory_bytes) + " (--memory-mb)");
    }
    for (int s = 1; s < S; ++s) local_[static_cast<size_t>(s)].table.assign(local_[static_cast<size_t>(s)].size, 0.0f);
    for (int s = S; s < k_; ++s) {
      Scanned& t = scanned_[static_cast<size_t>(s)];
      t.table.assign(t.size, 0.0f);
      if (missing_) t.availability.assign(t.size, DiamondAvailability{});
    }
    if (!missing_) finest_max_.assign(grid_.Count(0), 0.0);
    coarse_.assign(coarse_size_, V{});
    window_.assign(static_cast<size_t>(slab_ + 2 * halo_) * plane_, V{});

    // With missing values every diamond is scanned and the finest octave's
    // errors are stored (DiamondErrors).
    DenseHeader params = ParamsFor(D, input_, options_, stored_, k_, fmin_, fmax_);
    if (missing_) params.flags = kDenseFinestStored;
    SDB_ASSIGN_OR_RETURN(writer_, DenseStoreWriter::Create(out_, params, WriteOptionsFor(options_, threads_)));
    AssignBlocks();

    diamonds_ = std::make_unique<DiamondErrors<D, V>>(window_.data(), dims_, k_, !IsFloatType(stored_),
                                                       fmax_ - fmin_, threads_, true, missing_);
    const int64_t slabs = last_vertex_plane_ / slab_ + 1;
    for (int64_t i = 0; i < slabs; ++i) {
      SDB_RETURN_IF_ERROR(Slab(i * slab_, i + 1 == slabs));
      if (options_.progress) {
        options_.progress({"slabs", static_cast<uint64_t>(i + 1), static_cast<uint64_t>(slabs),
                           std::chrono::duration<double>(Clock::now() - start_).count()});
      }
    }
    // The scanned scales' blocks (and those spanning several octaves).
    SDB_RETURN_IF_ERROR(writer_->WriteBlocks(scanned_blocks_, [&](int, uint64_t first, size_t count,
                                                                  double* errors) -> Status {
      for (size_t i = 0; i < count; ++i) {
        std::array<int64_t, D> g{};
        if (!order_.Decode(first + i, g)) continue;
        const int level = order_.Level(g);
        if (level < 0) continue;
        const int s = k_ - 1 - level / D;
        if (s < S) continue;  // finest positions past the stored ones (not written)
        errors[i] = ScannedAt(g, s);
        if (missing_) {
          errors[i] = diamonds_->MergedError(
              errors[i], scanned_[static_cast<size_t>(s)].availability[ScannedIndex(g, s)]);
        }
      }
      return Status::OK();
    }));
    // The coarse lattices' bricks.
    std::vector<uint64_t> coarse_bricks;
    for (int s = kCoarseShift; s < grid_.lattices(); ++s) {
      for (uint64_t b = grid_.FirstBrick(s); b < grid_.FirstBrick(s) + grid_.Count(s); ++b) coarse_bricks.push_back(b);
    }
    HeldField<V> held{coarse_.data(), {}, 0, kCoarseShift};
    for (int a = 0; a < 4; ++a) held.stride[a] = a < D ? coarse_stride_[a] : 0;
    SDB_RETURN_IF_ERROR(writer_->WriteBricks(coarse_bricks, held, FinestMax()));
    DenseBuildReport report;
    SDB_ASSIGN_OR_RETURN(report.header, writer_->Finish());
    report.grid_points = n_;
    report.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
    report.method = "streamed";
    return report;
  }

 private:
  struct Local {  // a local scale's table: one chunk of planes
    int64_t chunk = 0;  // planes per chunk (a multiple of the slab or of it)
    std::array<int64_t, D> extent{};
    std::array<uint64_t, D> stride{};
    uint64_t size = 0;
    std::vector<float> table;
    std::vector<std::vector<uint64_t>> blocks;  // candidates by chunk
  };
  struct Scanned {  // a scanned scale's maxima: every vertex of the domain
    std::array<uint64_t, D> stride{};
    uint64_t size = 0;
    std::vector<float> table;
    std::vector<DiamondAvailability> availability;  // with missing values
  };

  // The bricks' largest finest errors for the writer; null when they are
  // stored (missing values).
  const double* FinestMax() const { return missing_ ? nullptr : finest_max_.data(); }

  uint64_t ScannedIndex(const std::array<int64_t, D>& g, int s) const {
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) i += static_cast<uint64_t>(g[a] >> s) * scanned_[static_cast<size_t>(s)].stride[a];
    return i;
  }
  double ScannedAt(const std::array<int64_t, D>& g, int s) const {
    return scanned_[static_cast<size_t>(s)].table[ScannedIndex(g, s)];
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

  // Pass 1: every plane, on every worker with its own reader.
  Status ReadRangeAndCorners() {
    stored_ = StoredVoxelType(input_, options_.mask.has_value());
    corners_.assign(corner_size_, 0.0);
    struct PlaneResult {
      Status status;
      bool missing = false;
      double min = std::numeric_limits<double>::infinity(), max = -min;
    };
    std::vector<PlaneResult> found(static_cast<size_t>(dims_[L]));
    std::vector<MaskedReader> reader = MakeReaders();
    std::vector<std::vector<double>> buffer(static_cast<size_t>(Readers()));
    const Status read = RunParallel(static_cast<uint64_t>(dims_[L]), Readers(), "field", start_,
                                    options_.progress, [&](int w, uint64_t z) -> Status {
      std::vector<double>& values = buffer[static_cast<size_t>(w)];
      SDB_RETURN_IF_ERROR(ReadPlane(reader[static_cast<size_t>(w)], static_cast<int64_t>(z), values));
      PlaneResult& result = found[z];
      result.status = CheckStorableValues(input_, z * plane_, values.data(), plane_);
      if (!result.status.ok()) return Status::OK();
      for (double& v : values) {
        if (std::isnan(v)) {
          result.missing = true;  // skipped by the range
          continue;
        }
        if (stored_ == VoxelType::kF32) v = static_cast<float>(v);
        result.min = std::min(result.min, v);
        result.max = std::max(result.max, v);
      }
      const int64_t cz = CornerIndex(L, static_cast<int64_t>(z));
      if (cz < 0) return Status::OK();
      std::array<int64_t, D> p{};
      p[L] = static_cast<int64_t>(z);
      // The plane's corner points (distinct planes: no race).
      ForEachCorner(p, [&](const std::array<int64_t, D>& q, uint64_t at) {
        uint64_t i = 0;
        for (int a = 0; a < L; ++a) i += static_cast<uint64_t>(q[a] * stride_[a]);
        corners_[at] = values[i];
      });
      return Status::OK();
    });
    SDB_RETURN_IF_ERROR(read);
    for (const PlaneResult& r : found) {
      if (!r.status.ok()) return r.status;
      missing_ = missing_ || r.missing;
      fmin_ = std::min(fmin_, r.min);
      fmax_ = std::max(fmax_, r.max);
    }
    if (fmin_ > fmax_) fmin_ = fmax_ = 0;  // every value missing
    return Status::OK();
  }
  // Workers reading the input: one for a gzip file (each reader inflates
  // everything before what it reads), else every one.
  int Readers() const { return input_.encoding == VolumeInfo::Encoding::kGzip ? 1 : threads_; }
  // One reader per worker.
  std::vector<MaskedReader> MakeReaders() const {
    std::vector<MaskedReader> readers;
    for (int w = 0; w < Readers(); ++w) readers.emplace_back(input_, options_.mask);
    return readers;
  }
  // Plane z of the input into `values`, masked points NaN.
  Status ReadPlane(MaskedReader& reader, int64_t z, std::vector<double>& values) {
    values.resize(plane_);
    return reader.Read(static_cast<uint64_t>(z) * plane_, plane_, values.data());
  }

  // The corner lattice's index of coordinate c on axis a, or -1.
  int64_t CornerIndex(int a, int64_t c) const {
    if (c % halo_ == 0) return c / halo_;
    if (c == dims_[a] - 1) return corner_count_[a] - 1;
    return -1;
  }
  // f(q, index) for the corner points q of the plane of p (p[L] a corner coordinate).
  template <class F>
  void ForEachCorner(const std::array<int64_t, D>& p, F&& f) const {
    std::array<int64_t, D> q = p;
    std::array<int64_t, D> idx{};
    idx[L] = CornerIndex(L, p[L]);
    for (int a = 0; a < L; ++a) q[a] = 0;
    while (true) {
      uint64_t at = 0;
      for (int a = 0; a < D; ++a) at += static_cast<uint64_t>(idx[a]) * corner_stride_[a];
      f(q, at);
      int a = 0;
      for (; a < L; ++a) {
        if (++idx[a] < corner_count_[a]) {
          q[a] = std::min(idx[a] * halo_, dims_[a] - 1);
          break;
        }
        idx[a] = 0;
        q[a] = 0;
      }
      if (a == L) break;
    }
  }
  double CornerAt(const std::array<int64_t, D>& c) const {
    uint64_t at = 0;
    for (int a = 0; a < D; ++a) {
      const int64_t i = CornerIndex(a, c[a]);
      assert(i >= 0);
      at += static_cast<uint64_t>(i) * corner_stride_[a];
    }
    return corners_[at];
  }

  // Each candidate block to the run that writes it: a local scale's to its
  // chunk, the others' to the end.
  void AssignBlocks() {
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
  // The readers stay open from slab to slab (a gzip file is read by one,
  // which would inflate everything before a plane if opened anew).
  Status ReadPlanes(int64_t lo, int64_t hi) {
    if (lo >= hi) return Status::OK();
    if (readers_.empty()) readers_ = MakeReaders();
    buffers_.resize(static_cast<size_t>(Readers()));
    return RunParallel(static_cast<uint64_t>(hi - lo), Readers(), "field", start_, {},
                       [&](int w, uint64_t i) -> Status {
      const int64_t z = lo + static_cast<int64_t>(i);
      std::vector<double>& values = buffers_[static_cast<size_t>(w)];
      SDB_RETURN_IF_ERROR(ReadPlane(readers_[static_cast<size_t>(w)], z, values));
      V* to = window_.data() + static_cast<size_t>(z - window_first_) * plane_;
      for (uint64_t j = 0; j < plane_; ++j) {
        const double v = stored_ == VoxelType::kF32 ? static_cast<double>(static_cast<float>(values[j])) : values[j];
        // NaN (missing) only in float fields: a masked integer volume is stored as float32.
        assert(std::is_floating_point_v<V> || !std::isnan(v));
        to[j] = static_cast<V>(v);
      }
      // Every 8th point of every 8th plane, for the coarse lattices' bricks.
      if (z % (int64_t{1} << kCoarseShift) == 0) {
        std::array<int64_t, D> q{};
        while (true) {
          uint64_t from = 0, at = static_cast<uint64_t>(z >> kCoarseShift) * static_cast<uint64_t>(coarse_stride_[L]);
          for (int a = 0; a < L; ++a) {
            from += static_cast<uint64_t>((q[a] << kCoarseShift) * stride_[a]);
            at += static_cast<uint64_t>(q[a]) * static_cast<uint64_t>(coarse_stride_[a]);
          }
          coarse_[at] = to[from];
          int a = 0;
          for (; a < L; ++a) {
            if (++q[a] < coarse_count_[a]) break;
            q[a] = 0;
          }
          if (a == L) break;
        }
      }
      return Status::OK();
    });
  }

  // Slab [z0, z0 + slab_): its window, its errors, its bricks, the chunks it completes.
  Status Slab(int64_t z0, bool last) {
    const int64_t z1 = z0 + slab_;
    // The window: real planes [z0 - halo, z1 + halo); keep what the last one read.
    const int64_t lo = std::max<int64_t>(0, z0 - halo_), hi = std::min(dims_[L], z1 + halo_);
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

    // Work items: local rows, scanned rows, finest boxes.
    struct Item {
      int kind;   // 0 local row, 1 scanned row, 2 finest box
      int s;
      int64_t j;  // row: last coordinate j * 2^s; box: the brick
    };
    std::vector<Item> items;
    for (int s = S - 1; s >= 1; --s) {
      const int64_t h = int64_t{1} << s;
      for (int64_t z = (z0 + h - 1) / h * h; z < z1 && z <= std::min(side_, dims_[L] - 1 + 2 * h); z += h) {
        items.push_back({0, s, z / h});
      }
    }
    const int64_t real_hi = std::min(z1, dims_[L]) - 1;  // the slab's real planes: [z0, real_hi]
    if (z0 <= real_hi) {
      for (int s = k_ - 1; s >= S; --s) {
        const int64_t h = int64_t{1} << s;
        for (int64_t z = std::max<int64_t>(0, (z0 - 2 * h + h - 1) / h * h); z <= std::min(side_, real_hi + 2 * h); z += h) {
          items.push_back({1, s, z / h});
        }
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
    // Local tables: the chunk holding this slab.
    const auto chunk_first = [&](int s) { return z0 / local_[static_cast<size_t>(s)].chunk * local_[static_cast<size_t>(s)].chunk; };
    const auto corner = [this](const std::array<int64_t, D>& c) { return CornerAt(c); };
    const Status computed = RunParallel(items.size(), threads_, "errors", start_, {}, [&](int, uint64_t i) -> Status {
      const Item it = items[i];
      if (it.kind == 0) {
        const int64_t cf = chunk_first(it.s);
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
    });
    SDB_RETURN_IF_ERROR(computed);
    HeldField<V> held{window_.data(), {}, window_first_, 0};
    held.stride[0] = 1;
    for (int a = 1; a < 4; ++a) held.stride[a] = a < D ? stride_[a] : 0;
    SDB_RETURN_IF_ERROR(writer_->WriteBricks(bricks, held, FinestMax()));

    // Stored finest blocks of this slab: computed from the window.
    const uint64_t slab = static_cast<uint64_t>(z0 / slab_);
    if (missing_ && slab < finest_blocks_.size()) {
      SDB_RETURN_IF_ERROR(writer_->WriteBlocks(finest_blocks_[slab], [&](int, uint64_t first, size_t count,
                                                                        double* errors) -> Status {
        for (size_t i = 0; i < count; ++i) {
          std::array<int64_t, D> g{};
          if (order_.Decode(first + i, g)) errors[i] = diamonds_->At(g, first + i);
        }
        return Status::OK();
      }));
    }

    // Chunks this slab completes: their blocks, then a clean table.
    for (int s = 1; s < S; ++s) {
      Local& t = local_[static_cast<size_t>(s)];
      if (!last && z1 % t.chunk != 0) continue;
      const int64_t cf = chunk_first(s);
      const uint64_t chunk = static_cast<uint64_t>(cf / t.chunk);
      if (chunk < t.blocks.size()) {
        SDB_RETURN_IF_ERROR(writer_->WriteBlocks(t.blocks[chunk], [&](int, uint64_t first, size_t count,
                                                                         double* errors) -> Status {
          for (size_t i = 0; i < count; ++i) {
            std::array<int64_t, D> g{};
            if (!order_.Decode(first + i, g)) continue;
            if (const float* slot = LocalSlot(g, s, cf)) errors[i] = *slot;
          }
          return Status::OK();
        }));
      }
      // (Chunks past the last slab hold no vertex with data: their
      // candidates are never written, so not stored.)
      std::fill(t.table.begin(), t.table.end(), 0.0f);
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
  std::array<int64_t, D> dims_{}, stride_{};  // the field's, x fastest
  uint64_t n_ = 1, plane_ = 1;
  int64_t slab_ = 0, halo_ = 0, last_vertex_plane_ = 0;
  std::array<Local, S> local_{};
  std::array<Scanned, kCoordBits<D>> scanned_{};
  std::array<int64_t, D> corner_count_{}, coarse_count_{}, coarse_stride_{};
  std::array<uint64_t, D> corner_stride_{};
  uint64_t corner_size_ = 0, coarse_size_ = 0;
  std::vector<double> corners_;
  std::vector<V> coarse_, window_;
  std::vector<double> finest_max_;
  std::vector<uint64_t> scanned_blocks_;
  std::vector<std::vector<uint64_t>> finest_blocks_;  // by slab (missing values)
  bool missing_ = false;  // the field has missing values (NaN)
  VoxelType stored_ = VoxelType::kU8;
  double fmin_ = std::numeric_limits<double>::infinity(), fmax_ = -fmin_;
  int64_t window_first_ = -1, window_end_ = -1;
  std::unique_ptr<DenseStoreWriter> writer_;
  std::unique_ptr<DiamondErrors<D, V>> diamonds_;
  std::vector<MaskedReader> readers_;  // pass 2's, per worker
  std::vector<std::vector<double>> buffers_;
};

}  // namespace

template <int D, class V>
std::optional<uint64_t> StreamedBytes(const VolumeInfo& input, const DenseBuildOptions& options, int k,
                                      int threads) {
  if (!StreamedBuild<D, V>::Applies(k, options.block_bits)) return std::nullopt;
  return StreamedBuild<D, V>(input, "", options, Clock::now(), k, threads).Bytes();
}

template <int D, class V>
Result<DenseBuildReport> BuildStreamed(const VolumeInfo& input, const std::string& out,
                                       const DenseBuildOptions& options, Clock::time_point start, int k,
                                       int threads) {
  return StreamedBuild<D, V>(input, out, options, start, k, threads).Run();
}

#define SDB_STREAMED_(V)                                                                          \
  template std::optional<uint64_t> StreamedBytes<3, V>(const VolumeInfo&, const DenseBuildOptions&,  \
                                                       int, int);                                 \
  template std::optional<uint64_t> StreamedBytes<4, V>(const VolumeInfo&, const DenseBuildOptions&,  \
                                                       int, int);                                 \
  template Result<DenseBuildReport> BuildStreamed<3, V>(const VolumeInfo&, const std::string&,       \
                                                        const DenseBuildOptions&, Clock::time_point,    \
                                                        int, int);                                   \
  template Result<DenseBuildReport> BuildStreamed<4, V>(const VolumeInfo&, const std::string&,       \
                                                        const DenseBuildOptions&, Clock::time_point,    \
                                                        int, int);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_STREAMED_)
#undef SDB_STREAMED_

}  // namespace simplexdb::dense_build
