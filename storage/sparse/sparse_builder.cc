#include "storage/sparse/sparse_builder.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "hierarchy/geometry.h"
#include "storage/dense/layout.h"
#include "storage/error/simplex_scan.h"
#include "storage/io/file.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/vertex_set.h"
#include "storage/volume/voxel_type.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

// The LMDB write batch of a conversion.
constexpr uint64_t kBatchBytes = uint64_t{16} << 20;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

template <int D>
std::array<int64_t, D> PointOfKey(uint64_t key, int domain_bits) {
  const uint64_t side = (uint64_t{1} << domain_bits) + 1;
  std::array<int64_t, D> p;
  for (int c = 0; c < D; ++c) {
    p[c] = static_cast<int64_t>(key % side);
    key /= side;
  }
  return p;
}

template <int D>
class DenseToSparse {
 public:
  DenseToSparse(const DenseStore& dense, lmdb::Env& env, MDB_dbi errors, MDB_dbi field,
                const SparseBuildOptions& options, Clock::time_point start)
      : dense_(dense),
        reader_(dense),
        errors_(errors),
        field_(field),
        options_(options),
        start_(start),
        k_(dense.header().domain_bits),
        leaf_(dense.header().leaf_level()),
        needed_(D, k_),
        writer_(env, kBatchBytes),
        layout_(leaf_, dense.header().levels_per_block) {
    ComputeSubtreeMaxima();
    // Every internal node of the complete hierarchy, for progress.
    total_ = uint64_t{SimplexCode<D>::kRoots} *
             (leaf_ >= 63 ? ~uint64_t{0} / SimplexCode<D>::kRoots : (uint64_t{1} << leaf_) - 1);
  }

  Status Run(SparseHeader* header) {
    for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
      SDB_ASSIGN_OR_RETURN(double m, Visit(SimplexCode<D>::Root(top), RootVertices<D>(top)));
      (void)m;
    }
    SDB_RETURN_IF_ERROR(WriteField());
    SDB_RETURN_IF_ERROR(writer_.Flush());
    header->nodes = nodes_;
    header->vertices = needed_.size();
    header->content_sum = sum_;
    return Status::OK();
  }

  uint64_t visited() const { return visited_; }
  uint64_t map_growths() const { return writer_.map_growths(); }

 private:
  struct Pending {
    SimplexCode<D> code;
    uint32_t stored;
    SimplexVertices<D> vertices;
  };

  // subtree_max_[b]: an upper bound of every error in the subtree of block
  // b's root: the block's own largest error (in its index entry) and those
  // of the blocks below it, bottom-up. The blocks of band j + 1 below block
  // s of band j are the contiguous subtrees [s << depth_j, (s + 1) << depth_j).
  void ComputeSubtreeMaxima() {
    subtree_max_.resize(layout_.block_count());
    for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
      const uint64_t base = static_cast<uint64_t>(top) * layout_.blocks_per_root();
      for (int band = layout_.bands() - 1; band >= 0; --band) {
        const uint64_t first = base + layout_.band_first(band);
        const uint64_t count = uint64_t{1} << layout_.band_start(band);
        for (uint64_t sub = 0; sub < count; ++sub) {
          float m = dense_.entry(first + sub).error_max;
          if (band + 1 < layout_.bands()) {
            const uint64_t below = base + layout_.band_first(band + 1) + (sub << layout_.band_depth(band));
            for (uint64_t c = 0; c < (uint64_t{1} << layout_.band_depth(band)); ++c) {
              m = std::max(m, subtree_max_[below + c]);
            }
          }
          subtree_max_[first + sub] = m;
        }
      }
    }
  }

  // Returns the largest error bound in `code`'s subtree.
  Result<double> Visit(SimplexCode<D> code, const SimplexVertices<D>& vertices) {
    if (code.level() >= leaf_) return 0.0;
    if (code.level() == layout_.band_start(layout_.BandOfLevel(code.level()))) {
      // A block's root: skip the whole subtree when nothing in it can
      // exceed the tolerance (the padding, uniform regions).
      const double bound = subtree_max_[layout_.Locate(code).block];
      if (bound <= options_.tolerance) return bound;
    }
    SDB_ASSIGN_OR_RETURN(const uint32_t stored, reader_.StoredError(code));
    const double e = dense_.quantizer().Decode(stored);
    if (options_.progress && (++visited_ & 0xfffff) == 0) {
      options_.progress(BuildProgress{"nodes", visited_, total_, SecondsSince(start_)});
    }
    pending_.push_back(Pending{code, stored, vertices});
    if (e > options_.tolerance) SDB_RETURN_IF_ERROR(EmitPending());
    double m = e;
    for (int child = 0; child < 2; ++child) {
      SDB_ASSIGN_OR_RETURN(const double c, Visit(code.child(child),
                                                 ChildVertices<D>(code, vertices, child)));
      m = std::max(m, c);
    }
    // Still pending: nothing in the subtree exceeds the tolerance. Drop it.
    if (!pending_.empty() && pending_.back().code == code) pending_.pop_back();
    return m;
  }

  // Writes the pending nodes (the open path, in preorder) and marks the
  // vertices their splits create.
  Status EmitPending() {
    const Quantization q = dense_.header().quantization;
    for (const Pending& p : pending_) {
      const auto key = lmdb::KeyBytes(p.code.key());
      uint8_t value[4];
      const size_t n = EncodeStoredError(q, p.stored, value);
      SDB_RETURN_IF_ERROR(writer_.Put(errors_, key, {value, n}, /*append=*/true));
      sum_ += SparseEntryHash(kErrorsDb, key, {value, n});
      ++nodes_;
      needed_.Insert(SparseStore::VertexKey<D>(
          LatticeToGrid<D>(SplitMidpoint<D>(p.code, p.vertices), k_), k_));
    }
    pending_.clear();
    return Status::OK();
  }

  Status WriteField() {
    for (const auto& corner : DomainCorners<D>(k_)) {
      needed_.Insert(SparseStore::VertexKey<D>(corner, k_));
    }
    const VoxelType type = dense_.header().voxel_type;
    const size_t voxel = VoxelSize(type);
    Status status;
    needed_.ForEach([&](uint64_t key) {
      if (!status.ok()) return;
      auto value = reader_.Field(PointOfKey<D>(key, k_));
      if (!value.ok()) {
        status = value.status();
        return;
      }
      std::byte bytes[8];
      EncodeVoxels(type, ByteOrder::kLittle, &*value, 1, bytes);
      const auto k = lmdb::KeyBytes(key);
      const std::span<const uint8_t> v(reinterpret_cast<const uint8_t*>(bytes), voxel);
      sum_ += SparseEntryHash(kFieldDb, k, v);
      status = writer_.Put(field_, k, v, /*append=*/true);
    });
    return status;
  }

  const DenseStore& dense_;
  DenseStore::Reader<D> reader_;
  MDB_dbi errors_, field_;
  const SparseBuildOptions& options_;
  Clock::time_point start_;
  int k_, leaf_;
  VertexSet needed_;
  lmdb::BatchWriter writer_;
  ErrorLayout<D> layout_;
  std::vector<float> subtree_max_;
  std::vector<Pending> pending_;
  uint64_t nodes_ = 0, sum_ = 0, visited_ = 0, total_ = 0;
};

// What DenseToSparse allocates: one bit per domain vertex (VertexSet), a
// float per error block (subtree_max_) and the write batch (kBatchBytes).
// ResourceExhausted with the figures, under `what`, when more than
// `memory_bytes`.
Status CheckConversionMemory(const std::string& what, int dimension, int domain_bits,
                             uint64_t error_blocks, uint64_t memory_bytes) {
  constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
  uint64_t points = 1;
  for (int c = 0; c < dimension; ++c) {
    const uint64_t side = (uint64_t{1} << domain_bits) + 1;
    points = points > kMax / side ? kMax : points * side;
  }
  const uint64_t vertices = points / 8 + 8;
  const uint64_t maxima = error_blocks > kMax / 4 ? kMax : error_blocks * 4;
  const uint64_t batch = kBatchBytes;
  const uint64_t total = vertices > kMax - maxima - batch ? kMax : vertices + maxima + batch;
  if (total <= memory_bytes) return Status::OK();
  const auto mib = [](uint64_t b) {
    return std::to_string((b >> 20) + ((b & ((uint64_t{1} << 20) - 1)) != 0)) + " MiB";
  };
  return Status::ResourceExhausted(
      what + ": converting to a sparse store needs about " + mib(total) +
      ": the vertex set of " + std::to_string(points) + " domain vertices, " + mib(vertices) +
      "; the subtree maxima of " + std::to_string(error_blocks) + " blocks, " + mib(maxima) +
      "; the write batch, " + mib(batch) + ". The memory bound (--memory-mb) is " +
      mib(memory_bytes) + ": give at least " + mib(total));
}

template <int D>
uint64_t ErrorBlocksFor(const VolumeInfo& input, int levels_per_block, int* domain_bits) {
  *domain_bits = std::max(1, DomainBitsFor(D, input.dims));
  return ErrorLayout<D>(D * *domain_bits, levels_per_block).block_count();
}

}  // namespace

Result<SparseBuildReport> ConvertDenseToSparse(const DenseStore& dense,
                                               const std::string& out_path,
                                               const SparseBuildOptions& options) {
  const Clock::time_point start = Clock::now();
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance)) {
    return Status::InvalidArgument("tolerance " + std::to_string(options.tolerance) +
                                   ": expected a finite number >= 0");
  }
  if (options.memory_bytes > 0) {
    // Named by the store's source: the input an import names (the dense
    // store may be its scratch file).
    const DenseHeader& h = dense.header();
    SDB_RETURN_IF_ERROR(CheckConversionMemory(h.source.empty() ? dense.path() : h.source,
                                              h.dimension, h.domain_bits, h.error_block_count,
                                              options.memory_bytes));
  }
  SDB_RETURN_IF_ERROR(PrepareOutput(out_path));
  TemporaryFile temp(out_path);  // LMDB writes it; renamed into place when complete
  SparseBuildReport report;
  {
    lmdb::Env::Options env_options;
    env_options.read_only = false;
    env_options.name = out_path;
    env_options.map_bytes = options.initial_map_bytes > 0 ? options.initial_map_bytes
                                                          : uint64_t{64} << 20;
    SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> env, lmdb::Env::Open(temp.path(), env_options));
    MDB_dbi errors, field, meta;
    {
      SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/false));
      SDB_ASSIGN_OR_RETURN(errors, txn.OpenDb("errors", true));
      SDB_ASSIGN_OR_RETURN(field, txn.OpenDb("field", true));
      SDB_ASSIGN_OR_RETURN(meta, txn.OpenDb("meta", true));
      SDB_RETURN_IF_ERROR(txn.Commit());
    }
    const DenseHeader& dh = dense.header();
    SparseHeader& h = report.header;
    h.dimension = dh.dimension;
    h.dims = dh.dims;
    h.domain_bits = dh.domain_bits;
    h.voxel_type = dh.voxel_type;
    h.quantization = dh.quantization;
    h.quantum = dh.quantum;
    h.field_min = dh.field_min;
    h.field_max = dh.field_max;
    h.error_max = dh.error_max;
    h.tolerance = options.tolerance;
    h.source = "dense store " + dense.path() + " (" + dh.source + ")";
    h.source.resize(Utf8PrefixLength(h.source, 1000));
    if (dh.dimension == 3) {
      DenseToSparse<3> run(dense, *env, errors, field, options, start);
      SDB_RETURN_IF_ERROR(run.Run(&h));
      report.nodes_visited = run.visited();
      report.map_growths = run.map_growths();
    } else {
      DenseToSparse<4> run(dense, *env, errors, field, options, start);
      SDB_RETURN_IF_ERROR(run.Run(&h));
      report.nodes_visited = run.visited();
      report.map_growths = run.map_growths();
    }
    lmdb::BatchWriter meta_writer(*env);
    static constexpr uint8_t kHeaderKey[] = {'h', 'e', 'a', 'd', 'e', 'r'};
    const std::string text = SerializeSparseHeader(h);
    SDB_RETURN_IF_ERROR(meta_writer.Put(
        meta, kHeaderKey, {reinterpret_cast<const uint8_t*>(text.data()), text.size()}, false));
    SDB_RETURN_IF_ERROR(meta_writer.Flush());
    report.map_growths += meta_writer.map_growths();
    SDB_RETURN_IF_ERROR(env->Sync());
  }  // closes the environment
  SDB_RETURN_IF_ERROR(temp.Commit());
  report.seconds = SecondsSince(start);
  std::error_code size_error;
  report.file_bytes = std::filesystem::file_size(out_path, size_error);
  if (options.progress) {
    options.progress(BuildProgress{"nodes", report.nodes_visited, report.nodes_visited,
                                        report.seconds});
  }
  return report;
}

Status CheckSparseImportMemory(const VolumeInfo& input, int levels_per_block,
                               uint64_t memory_bytes) {
  if (memory_bytes == 0 || (input.dimension != 3 && input.dimension != 4)) return Status::OK();
  if (levels_per_block < 1 || levels_per_block > 24) return Status::OK();  // the builder says
  int k = 0;
  const int max_bits = input.dimension == 3 ? 18 : 13;
  if (std::max(1, DomainBitsFor(input.dimension, input.dims)) > max_bits) {
    return Status::OK();  // beyond the location code: the builder says so
  }
  const uint64_t blocks = input.dimension == 3 ? ErrorBlocksFor<3>(input, levels_per_block, &k)
                                               : ErrorBlocksFor<4>(input, levels_per_block, &k);
  return CheckConversionMemory(input.description, input.dimension, k, blocks, memory_bytes);
}

namespace {

template <int D>
class FieldRebuilder {
 public:
  FieldRebuilder(const SparseStore& sparse, SparseStore::Reader<D>& reader, std::byte* out)
      : sparse_(sparse),
        h_(sparse.header()),
        reader_(reader),
        out_(out),
        voxel_(VoxelSize(h_.voxel_type)) {
    for (int c = 0; c < D; ++c) hi_[c] = int64_t{h_.dims[c]} - 1;
  }

  Status Run() {
    for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
      const SimplexCode<D> root = SimplexCode<D>::Root(top);
      Node node{RootVertices<D>(top), {}};
      for (int i = 0; i <= D; ++i) {
        SDB_ASSIGN_OR_RETURN(node.values[i], Value(LatticeToGrid<D>(node.vertices[i], h_.domain_bits)));
      }
      SDB_RETURN_IF_ERROR(Visit(root, node));
    }
    return WriteStoredValues();
  }

 private:
  struct Node {
    SimplexVertices<D> vertices;
    std::array<double, D + 1> values;
  };

  Result<double> Value(const IPoint<D>& p) {
    SDB_ASSIGN_OR_RETURN(std::optional<double> v, reader_.Field(p));
    if (!v) {
      return Status::Corruption(sparse_.path() + ": vertex " +
                                std::to_string(SparseStore::VertexKey<D>(p, h_.domain_bits)) +
                                " of a present node is not stored");
    }
    return *v;
  }

  Status Visit(SimplexCode<D> code, const Node& node) {
    bool present = false;
    if (code.level() < h_.leaf_level()) {
      SDB_ASSIGN_OR_RETURN(std::optional<uint32_t> stored, reader_.FindStored(code));
      present = stored.has_value();
    }
    if (!present) {
      Rasterize(node);
      return Status::OK();
    }
    SDB_ASSIGN_OR_RETURN(const double mid_value,
                         Value(LatticeToGrid<D>(SplitMidpoint<D>(code, node.vertices),
                                                         h_.domain_bits)));
    for (int child = 0; child < 2; ++child) {
      Node next;
      next.vertices = ChildVertices<D>(code, node.vertices, child);
      for (int i = 0; i <= D; ++i) {
        // Each child vertex is the midpoint or one of the parent's vertices.
        next.values[i] = mid_value;
        for (int j = 0; j <= D; ++j) {
          if (node.vertices[j] == next.vertices[i]) next.values[i] = node.values[j];
        }
      }
      SDB_RETURN_IF_ERROR(Visit(code.child(child), next));
    }
    return Status::OK();
  }

  // Writes the interpolation over a leaf at the real grid points in it.
  void Rasterize(const Node& node) {
    std::array<IPoint<D>, D + 1> v;
    for (int i = 0; i <= D; ++i) v[i] = LatticeToGrid<D>(node.vertices[i], h_.domain_bits);
    const ScannableSimplex<D> s(v);
    const std::array<double, D> g = s.template ScaledGradient<double>(node.values);
    const double det = static_cast<double>(s.det());
    const IPoint<D> lo{};
    s.ForEachRow(lo, hi_, [&](IPoint<D> p, int64_t x_end) {
      double along = 0;
      for (int c = 1; c < D; ++c) along += g[c] * static_cast<double>(p[c] - v[0][c]);
      for (int64_t x = p[0]; x <= x_end; ++x) {
        const double value =
            node.values[0] + (along + g[0] * static_cast<double>(x - v[0][0])) / det;
        p[0] = x;
        Write(p, value);
      }
    });
  }

  // The offset of real grid point p in the rebuilt volume (x fastest).
  uint64_t IndexOf(const IPoint<D>& p) const {
    uint64_t index = 0;
    for (int c = D - 1; c >= 0; --c) index = index * h_.dims[c] + static_cast<uint64_t>(p[c]);
    return index;
  }

  void Write(const IPoint<D>& p, double value) {
    const uint64_t index = IndexOf(p);
    double v = std::clamp(value, h_.field_min, h_.field_max);
    if (!IsFloatType(h_.voxel_type)) v = std::round(v);
    EncodeVoxels(h_.voxel_type, ByteOrder::kLittle, &v, 1, out_ + index * voxel_);
  }

  // Stored values are the data itself: they win over any interpolation.
  Status WriteStoredValues() {
    SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(sparse_.env(), /*read_only=*/true));
    SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor,
                         lmdb::Cursor::Open(txn, sparse_.field_db()));
    MDB_val k, v;
    int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST);
    for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
      if (k.mv_size != 8 || v.mv_size != voxel_) {
        return Status::Corruption(sparse_.path() + ": a field entry of the wrong size");
      }
      const auto p = PointOfKey<D>(lmdb::KeyValue(k), h_.domain_bits);
      bool inside = true;
      for (int c = 0; c < D; ++c) inside = inside && p[c] <= hi_[c];
      if (!inside) continue;
      std::copy_n(static_cast<const std::byte*>(v.mv_data), voxel_, out_ + IndexOf(p) * voxel_);
    }
    if (rc != MDB_NOTFOUND) return sparse_.env().FromCode(rc, "read the field");
    return Status::OK();
  }

  const SparseStore& sparse_;
  const SparseHeader& h_;
  SparseStore::Reader<D>& reader_;
  std::byte* out_;
  size_t voxel_;
  IPoint<D> hi_{};
};

template <int D>
Status RebuildField(const SparseStore& sparse, std::byte* out) {
  SDB_ASSIGN_OR_RETURN(auto reader, SparseStore::Reader<D>::Create(sparse));
  FieldRebuilder<D> rebuilder(sparse, reader, out);
  return rebuilder.Run();
}

}  // namespace

Result<DenseBuildReport> ConvertSparseToDense(const SparseStore& sparse,
                                              const std::string& out_path,
                                              DenseBuildOptions options) {
  const SparseHeader& h = sparse.header();
  uint64_t points = 1;
  for (int c = 0; c < h.dimension; ++c) points *= h.dims[c];
  // The raw field is a scratch file of the output (removed on every path
  // out, and by the next run of the same output if this process dies).
  SDB_RETURN_IF_ERROR(PrepareOutput(out_path));
  const TemporaryFile field(out_path, "field");
  const std::string& field_path = field.path();
  SDB_ASSIGN_OR_RETURN(auto scratch,
                       WritableScratchMapping::Create(field_path, points * VoxelSize(h.voxel_type)));
  SDB_RETURN_IF_ERROR(h.dimension == 3 ? RebuildField<3>(sparse, scratch->data())
                                       : RebuildField<4>(sparse, scratch->data()));
  SDB_RETURN_IF_ERROR(scratch->Flush());
  SDB_ASSIGN_OR_RETURN(VolumeInfo volume,
                       OpenRawVolume(field_path, h.dimension, h.dims, h.voxel_type,
                                     ByteOrder::kLittle, 0));
  volume.description = "sparse store " + sparse.path();
  options.quantization = h.quantization;
  return BuildDenseStore(volume, out_path, options);
}

}  // namespace simplexdb
