#include "storage/sparse/sparse_update.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "storage/io/lmdb.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"
#include "storage/error/quantize.h"
#include "storage/error/unit_errors.h"
#include "storage/volume/voxel_type.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

constexpr uint8_t kHeaderKey[] = {'h', 'e', 'a', 'd', 'e', 'r'};

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

template <int D>
class Updater {
 public:
  Updater(const SparseHeader& h, const VolumeInfo& volume, VolumeReader& reader,
          VolumeReader* mask, const GridBox& box, const SparseUpdateOptions& options,
          Clock::time_point start)
      : h_(h),
        volume_(volume),
        reader_(reader),
        mask_(mask),
        options_(options),
        start_(start),
        k_(h.domain_bits),
        leaf_(h.leaf_level()),
        // Units: simplices of side about 2^6 (3D) or 2^4 (4D).
        unit_level_(D * std::max(0, h.domain_bits - (D == 3 ? 6 : 4))),
        quantizer_(h.quantization, h.quantum, h.field_max - h.field_min) {
    const int64_t side_last = int64_t{1} << k_;
    rules_.range = h.field_max - h.field_min;
    rules_.exact = !IsFloatType(h.voxel_type);
    // The store does not say whether the volume has missing values: any
    // float may (a NaN, or a mask: masked integers are stored as float32).
    rules_.may_miss = IsFloatType(h.voxel_type);
    for (int c = 0; c < D; ++c) {
      real_hi_[c] = static_cast<int64_t>(h.dims[c]) - 1;
      rules_.real_hi[c] = real_hi_[c];
      ebox_lo_[c] = box.lo[c];
      // Domain points past the real grid take the last real value: a box
      // that reaches the real grid's far face reaches the domain's.
      ebox_hi_[c] = box.hi[c] == real_hi_[c] ? side_last : box.hi[c];
    }
  }

  // The errors of every node whose simplex meets the box, by the dense
  // builder's engine (storage/error/unit_errors.h) over the units that meet
  // it or lie under an ancestor that does.
  Status ComputeErrors();

  // Writes the update in `txn` (the header included). `*map_full` is set,
  // with a failed status, when a write found the map full: abort, grow the
  // map, and call again in a new transaction.
  Status Apply(lmdb::Txn& txn, SparseUpdateReport* report, bool* map_full);

 private:
  GridSimplex<D> Grid(const SimplexVertices<D>& v) const { return GridOf<D>(v, k_); }

  // Whether the simplex's bounding box meets the (grown) box: a superset of
  // the simplices that meet it, which is all the update needs (recomputing
  // an unchanged node gives its old error back).
  bool Meets(const GridSimplex<D>& g) const {
    for (int c = 0; c < D; ++c) {
      int64_t lo = g[0][c], hi = g[0][c];
      for (int i = 1; i <= D; ++i) {
        lo = std::min(lo, g[i][c]);
        hi = std::max(hi, g[i][c]);
      }
      if (hi < ebox_lo_[c] || lo > ebox_hi_[c]) return false;
    }
    return true;
  }

  uint64_t VoxelIndex(const IPoint<D>& p) const {
    uint64_t i = 0;
    for (int c = D - 1; c >= 0; --c) {
      i = i * h_.dims[c] + static_cast<uint64_t>(std::min(p[c], real_hi_[c]));
    }
    return i;
  }

  Status CheckRange(double v, const IPoint<D>& p) const {
    if (v >= h_.field_min && v <= h_.field_max) return Status::OK();
    if (std::isnan(v)) return Status::OK();  // a missing value
    std::string at;
    for (int c = 0; c < D; ++c) {
      if (c > 0) at += ',';
      at += std::to_string(p[c]);
    }
    return Status::InvalidArgument(fmt::format(
        "{}: value {} at ({}) is outside the store's field range [{}, {}], which fixes its "
        "error quantum; import the volume again",
        volume_.description, v, at, h_.field_min, h_.field_max));
  }

  // Reads `count` voxels from `first`; masked ones become NaN (as the dense
  // builder stores them).
  Status Read(uint64_t first, size_t count, double* out) {
    SDB_RETURN_IF_ERROR(reader_.Read(first, count, out));
    if (mask_ != nullptr) {
      mask_row_.resize(count);
      SDB_RETURN_IF_ERROR(mask_->Read(first, count, mask_row_.data()));
      ApplyMask(mask_row_.data(), count, out);
    }
    return CheckStorableValues(volume_, first, out, count);
  }

  // Reads a unit's region (its box set), clamped to the real grid, row by
  // row.
  Status Fill(GridRegion<D>& r) {
    const int64_t width = r.hi[0] - r.lo[0] + 1;
    const int64_t x_end = std::min(r.hi[0], real_hi_[0]);
    IPoint<D> p = r.lo;
    double* out = r.values.data();
    while (true) {
      // The real part of the row, then the padding along x.
      const int64_t x0 = std::min(r.lo[0], real_hi_[0]);
      const int64_t real = x_end >= r.lo[0] ? x_end - r.lo[0] + 1 : 0;
      IPoint<D> first = p;
      first[0] = x0;
      if (real > 0) {
        SDB_RETURN_IF_ERROR(Read(VoxelIndex(first), static_cast<size_t>(real), out));
      } else {
        SDB_RETURN_IF_ERROR(Read(VoxelIndex(first), 1, out));
      }
      for (int64_t i = std::max<int64_t>(real, 1); i < width; ++i) out[i] = out[i - 1];
      for (int64_t i = 0; i < std::max<int64_t>(real, 1); ++i) {
        IPoint<D> q = first;
        q[0] = x0 + i;
        SDB_RETURN_IF_ERROR(CheckRange(out[i], q));
      }
      out += width;
      if (!NextRow<D>(p, r.lo, r.hi)) break;
    }
    return Status::OK();
  }

  Result<double> FieldAt(const IPoint<D>& p) {
    double v = 0;
    SDB_RETURN_IF_ERROR(Read(VoxelIndex(p), 1, &v));
    SDB_RETURN_IF_ERROR(CheckRange(v, p));
    return v;
  }

  Result<std::array<double, D + 1>> VertexValues(const GridSimplex<D>& g) {
    std::array<double, D + 1> f{};
    for (int i = 0; i <= D; ++i) {
      SDB_ASSIGN_OR_RETURN(f[i], FieldAt(g[i]));
    }
    return f;
  }

  void Raise(SimplexCode<D> code, double e) {
    auto [it, inserted] = errors_.try_emplace(code.key(), e);
    if (!inserted) it->second = std::max(it->second, e);
  }

  void Progress(uint64_t done, uint64_t total) {
    if (options_.progress) {
      options_.progress(BuildProgress{"units", done, total, SecondsSince(start_)});
    }
  }

  // --- writing ---

  Status Check(int rc, std::string_view what) {
    if (rc == MDB_SUCCESS) return Status::OK();
    if (rc == MDB_MAP_FULL) *map_full_ = true;
    if (rc == MDB_TXN_FULL) {
      return Status::ResourceExhausted(
          h_path_ + ": the update changes more pages than one LMDB transaction holds; nothing was "
                    "written (update a smaller box, or import the volume again)");
    }
    return txn_->env().FromCode(rc, what);
  }

  Result<std::optional<std::span<const uint8_t>>> Get(MDB_dbi dbi, uint64_t key) {
    const auto k = lmdb::KeyBytes(key);
    bool found = false;
    SDB_ASSIGN_OR_RETURN(const auto v, txn_->Get(dbi, k, &found));
    if (!found) return std::optional<std::span<const uint8_t>>();
    return std::optional<std::span<const uint8_t>>(v);
  }

  Status Put(int db, MDB_dbi dbi, uint64_t key, std::span<const uint8_t> value,
             std::optional<std::span<const uint8_t>> old) {
    const auto k = lmdb::KeyBytes(key);
    if (old) sum_ -= SparseEntryHash(db, k, *old);
    sum_ += SparseEntryHash(db, k, value);
    MDB_val kv = lmdb::Val(k.data(), k.size()), vv = lmdb::Val(value.data(), value.size());
    return Check(mdb_put(txn_->get(), dbi, &kv, &vv, 0), "write");
  }

  Status Delete(int db, MDB_dbi dbi, uint64_t key, std::span<const uint8_t> old) {
    const auto k = lmdb::KeyBytes(key);
    sum_ -= SparseEntryHash(db, k, old);
    MDB_val kv = lmdb::Val(k.data(), k.size());
    return Check(mdb_del(txn_->get(), dbi, &kv, nullptr), "delete");
  }

  Result<bool> Present(SimplexCode<D> code) {
    SDB_ASSIGN_OR_RETURN(const auto v, Get(errors_db_, code.key()));
    return v.has_value();
  }

  uint64_t MidpointKey(SimplexCode<D> code, const SimplexVertices<D>& v) const {
    return SparseStore::VertexKey<D>(LatticeToGrid<D>(SplitMidpoint<D>(code, v), k_), k_);
  }

  // Decides a node that meets the box (and, first, its children): present
  // when its error or anything below it exceeds the tolerance. Returns that.
  Result<bool> Decide(SimplexCode<D> code, const SimplexVertices<D>& v) {
    const double raw = errors_.at(code.key());
    const uint32_t stored = quantizer_.Encode(raw);
    bool keep = quantizer_.Decode(stored) > h_.tolerance;
    max_recomputed_ = std::max(max_recomputed_, raw);
    if (code.level() + 1 < leaf_) {
      for (int child = 0; child < 2; ++child) {
        const SimplexCode<D> c = code.child(child);
        if (errors_.contains(c.key())) {
          SDB_ASSIGN_OR_RETURN(const bool k, Decide(c, ChildVertices<D>(code, v, child)));
          keep = keep || k;
        } else {
          // Away from the box: unchanged, and present exactly when its
          // subtree holds an error above the tolerance.
          SDB_ASSIGN_OR_RETURN(const bool present, Present(c));
          keep = keep || present;
        }
      }
    }
    SDB_ASSIGN_OR_RETURN(const auto old, Get(errors_db_, code.key()));
    if (keep) {
      uint8_t bytes[4];
      const size_t n = EncodeStoredError(h_.quantization, stored, bytes);
      const std::span<const uint8_t> value(bytes, n);
      if (!old || !std::equal(old->begin(), old->end(), value.begin(), value.end())) {
        SDB_RETURN_IF_ERROR(Put(kErrorsDb, errors_db_, code.key(), value, old));
        ++report_->nodes_written;
        if (!old) {
          ++nodes_;
          appeared_.push_back(MidpointKey(code, v));
        }
      }
    } else if (old) {
      SDB_RETURN_IF_ERROR(Delete(kErrorsDb, errors_db_, code.key(), *old));
      ++report_->nodes_deleted;
      --nodes_;
      vanished_.push_back({code, MidpointKey(code, v)});
    }
    return keep;
  }

  Result<std::vector<uint8_t>> EncodedField(uint64_t key) {
    const uint64_t side = h_.domain_side();
    IPoint<D> p{};
    for (int c = 0; c < D; ++c) {
      p[c] = static_cast<int64_t>(key % side);
      key /= side;
    }
    SDB_ASSIGN_OR_RETURN(const double value, FieldAt(p));
    std::vector<uint8_t> bytes(VoxelSize(h_.voxel_type));
    EncodeVoxels(h_.voxel_type, ByteOrder::kLittle, &value, 1,
                 reinterpret_cast<std::byte*>(bytes.data()));
    return bytes;
  }

  // Stored vertices inside the grown box take the new values: one cursor
  // range per row (a row's keys are consecutive).
  Status RewriteBoxValues() {
    SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(*txn_, field_db_));
    const uint64_t side = h_.domain_side();
    IPoint<D> lo{}, hi{};
    for (int c = 0; c < D; ++c) {
      lo[c] = ebox_lo_[c];
      hi[c] = std::min<int64_t>(ebox_hi_[c], static_cast<int64_t>(side) - 1);
    }
    IPoint<D> p = lo;
    while (true) {
      IPoint<D> first = p, last = p;
      first[0] = lo[0];
      last[0] = hi[0];
      const uint64_t k0 = SparseStore::VertexKey<D>(first, k_);
      const uint64_t k1 = SparseStore::VertexKey<D>(last, k_);
      auto key = lmdb::KeyBytes(k0);
      MDB_val kv = lmdb::Val(key.data(), key.size()), vv;
      int rc = mdb_cursor_get(cursor.get(), &kv, &vv, MDB_SET_RANGE);
      while (rc == MDB_SUCCESS && lmdb::KeyValue(kv) <= k1) {
        const uint64_t at = lmdb::KeyValue(kv);
        SDB_ASSIGN_OR_RETURN(const auto fresh, EncodedField(at));
        const std::span<const uint8_t> old(static_cast<const uint8_t*>(vv.mv_data), vv.mv_size);
        if (!std::equal(old.begin(), old.end(), fresh.begin(), fresh.end())) {
          const auto k = lmdb::KeyBytes(at);
          sum_ -= SparseEntryHash(kFieldDb, k, old);
          sum_ += SparseEntryHash(kFieldDb, k, fresh);
          MDB_val nv = lmdb::Val(fresh.data(), fresh.size());
          SDB_RETURN_IF_ERROR(Check(mdb_cursor_put(cursor.get(), &kv, &nv, MDB_CURRENT), "write"));
          ++report_->vertices_written;
        }
        rc = mdb_cursor_get(cursor.get(), &kv, &vv, MDB_NEXT);
      }
      if (rc != MDB_SUCCESS && rc != MDB_NOTFOUND) SDB_RETURN_IF_ERROR(Check(rc, "read"));
      if (!NextRow<D>(p, lo, hi)) break;
    }
    return Status::OK();
  }

  // The vertices that nodes appearing or vanishing add or free.
  Status UpdateVertices() {
    for (const uint64_t key : appeared_) {
      SDB_ASSIGN_OR_RETURN(const auto old, Get(field_db_, key));
      if (old) continue;
      SDB_ASSIGN_OR_RETURN(const auto bytes, EncodedField(key));
      SDB_RETURN_IF_ERROR(Put(kFieldDb, field_db_, key, bytes, std::nullopt));
      ++vertices_;
      ++report_->vertices_written;
    }
    for (const auto& [code, key] : vanished_) {
      // The nodes that split the same edge are its cluster: the vertex
      // stays while one of them is present (corners are never midpoints).
      bool needed = false;
      for (const SimplexCode<D> member : Cluster(code)) {
        SDB_ASSIGN_OR_RETURN(const bool present, Present(member));
        if (present) {
          needed = true;
          break;
        }
      }
      if (needed) continue;
      SDB_ASSIGN_OR_RETURN(const auto old, Get(field_db_, key));
      if (!old) continue;  // freed already, by another member
      const std::vector<uint8_t> bytes(old->begin(), old->end());
      SDB_RETURN_IF_ERROR(Delete(kFieldDb, field_db_, key, bytes));
      --vertices_;
      ++report_->vertices_deleted;
    }
    return Status::OK();
  }

  // The header's error bound: the largest error of the volume. Exact when
  // the recomputed nodes hold it; otherwise the largest of the recomputed
  // errors, the other stored bounds (rounded up to the quantum) and, for a
  // lossy store, the dropped nodes' (at most the tolerance).
  Result<double> ErrorMax(double old_max) {
    if (max_recomputed_ >= old_max) return max_recomputed_;
    double m = max_recomputed_;
    if (h_.tolerance > 0) m = std::max(m, std::min(old_max, h_.tolerance));
    SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(*txn_, errors_db_));
    MDB_val kv, vv;
    int rc = mdb_cursor_get(cursor.get(), &kv, &vv, MDB_FIRST);
    for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &kv, &vv, MDB_NEXT)) {
      if (errors_.contains(lmdb::KeyValue(kv))) continue;
      const auto stored = DecodeStoredError(
          h_.quantization, {static_cast<const uint8_t*>(vv.mv_data), vv.mv_size});
      if (stored) m = std::max(m, quantizer_.Decode(*stored));
    }
    if (rc != MDB_NOTFOUND) SDB_RETURN_IF_ERROR(Check(rc, "read the errors"));
    return std::min(m, old_max);
  }

  const SparseHeader& h_;
  const VolumeInfo& volume_;
  VolumeReader& reader_;
  VolumeReader* mask_;  // null: no mask
  const SparseUpdateOptions& options_;
  Clock::time_point start_;
  const int k_, leaf_, unit_level_;
  ErrorQuantizer quantizer_;
  ErrorRules<D> rules_;
  IPoint<D> real_hi_{}, ebox_lo_{}, ebox_hi_{};
  std::unordered_map<uint64_t, double> errors_;  // code key -> recomputed error
  std::vector<double> mask_row_;

  // The transaction being written (Apply).
  lmdb::Txn* txn_ = nullptr;
  bool* map_full_ = nullptr;
  SparseUpdateReport* report_ = nullptr;
  std::string h_path_;
  MDB_dbi errors_db_ = 0, field_db_ = 0;
  uint64_t sum_ = 0, nodes_ = 0, vertices_ = 0;
  double max_recomputed_ = 0;
  std::vector<uint64_t> appeared_;
  std::vector<std::pair<SimplexCode<D>, uint64_t>> vanished_;
};

template <int D>
Status Updater<D>::ComputeErrors() {
  const uint64_t units_per_root = uint64_t{1} << unit_level_;
  uint64_t roots = 0;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    roots += Meets(Grid(RootVertices<D>(top)));
  }
  const uint64_t total = roots * units_per_root;
  uint64_t done = 0;
  const auto meets = [this](const GridSimplex<D>& g) { return Meets(g); };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    if (!Meets(Grid(RootVertices<D>(top)))) continue;
    // The interpolants of the nodes above the units that meet the box,
    // and where they have values (Availability).
    std::unordered_map<uint64_t, AncestorInterpolant<D>> above;
    std::unordered_map<uint64_t, Availability> above_availability;
    for (uint64_t u = 0; u < units_per_root; ++u, ++done) {
      if ((done & 63) == 0) Progress(done, total);
      const SimplexCode<D> unit = SimplexCode<D>::FromPath(top, u, unit_level_);
      const GridSimplex<D> grid = Grid(Vertices(unit));
      std::array<SimplexCode<D>, UnitScan<D>::kMaxAncestors> codes;
      std::array<AncestorInterpolant<D>, UnitScan<D>::kMaxAncestors> interps;
      int n = 0;
      for (int l = 0; l < unit_level_; ++l) {
        const SimplexCode<D> a = unit.ancestor(l);
        const GridSimplex<D> ag = Grid(Vertices(a));
        if (!Meets(ag)) continue;
        Raise(a, 0);
        auto it = above.find(a.key());
        if (it == above.end()) {
          SDB_ASSIGN_OR_RETURN(const auto f, VertexValues(ag));
          it = above.emplace(a.key(), AncestorInterpolant<D>(rules_, ag, f)).first;
          above_availability[a.key()].any_missing = it->second.vertex_missing();
        }
        codes[n] = a;
        interps[n++] = it->second;
      }
      const bool unit_meets = Meets(grid);
      if (n == 0 && !unit_meets) continue;
      UnitScan<D> scan(rules_, unit, grid);
      if (!scan.has_real_points()) continue;
      SDB_RETURN_IF_ERROR(Fill(scan.region()));
      if (n > 0) {
        std::array<double, UnitScan<D>::kMaxAncestors> partial{};
        const Availability a =
            scan.AncestorPartials({interps.data(), static_cast<size_t>(n)}, partial.data());
        for (int j = 0; j < n; ++j) {
          Raise(codes[j], partial[j]);
          above_availability[codes[j].key()].Merge(a);
        }
      }
      if (unit_meets) {
        scan.ForEachNode(leaf_, meets,
                         [&](const UnitNode<D>& node) { Raise(node.code, node.error); });
      }
    }
    // As the dense builder: 0 where no point has a value, the field range
    // where some have none.
    for (const auto& [key, a] : above_availability) {
      double& e = errors_.at(key);
      e = ErrorGivenAvailability(a, e, rules_.range);
    }
  }
  Progress(total, total);
  return Status::OK();
}

template <int D>
Status Updater<D>::Apply(lmdb::Txn& txn, SparseUpdateReport* report, bool* map_full) {
  txn_ = &txn;
  map_full_ = map_full;
  *report = SparseUpdateReport{};
  report_ = report;
  h_path_ = txn.env().path();
  appeared_.clear();
  vanished_.clear();
  max_recomputed_ = 0;
  SDB_ASSIGN_OR_RETURN(const MDB_dbi meta, txn.OpenDb("meta", false));
  SDB_ASSIGN_OR_RETURN(errors_db_, txn.OpenDb("errors", false));
  SDB_ASSIGN_OR_RETURN(field_db_, txn.OpenDb("field", false));
  // The header as this transaction sees it: another writer may have come
  // first.
  bool found = false;
  SDB_ASSIGN_OR_RETURN(const auto text, txn.Get(meta, kHeaderKey, &found));
  if (!found) return Status::Corruption(h_path_ + ": sparse store without a header");
  SDB_ASSIGN_OR_RETURN(
      SparseHeader now,
      ParseSparseHeader({reinterpret_cast<const char*>(text.data()), text.size()}, h_path_));
  if (now.quantum != h_.quantum || now.tolerance != h_.tolerance ||
      now.field_min != h_.field_min || now.field_max != h_.field_max ||
      now.domain_bits != h_.domain_bits) {
    return Status::InvalidArgument(h_path_ + ": the store changed while the update was computed");
  }
  sum_ = now.content_sum;
  nodes_ = now.nodes;
  vertices_ = now.vertices;
  report->nodes_recomputed = errors_.size();

  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    const SimplexCode<D> root = SimplexCode<D>::Root(top);
    if (!errors_.contains(root.key())) continue;
    SDB_ASSIGN_OR_RETURN(const bool keep, Decide(root, RootVertices<D>(top)));
    (void)keep;
  }
  SDB_RETURN_IF_ERROR(UpdateVertices());
  SDB_RETURN_IF_ERROR(RewriteBoxValues());
  SDB_ASSIGN_OR_RETURN(now.error_max, ErrorMax(now.error_max));
  now.content_sum = sum_;
  now.nodes = nodes_;
  now.vertices = vertices_;
  const std::string header = SerializeSparseHeader(now);
  MDB_val kv = lmdb::Val(kHeaderKey, sizeof kHeaderKey), vv = lmdb::Val(header.data(), header.size());
  SDB_RETURN_IF_ERROR(Check(mdb_put(txn.get(), meta, &kv, &vv, 0), "write the header"));
  report->header = now;
  return Status::OK();
}

template <int D>
Result<SparseUpdateReport> Update(const std::string& path, const SparseHeader& h,
                                  const VolumeInfo& volume, const GridBox& box,
                                  const SparseUpdateOptions& options, Clock::time_point start) {
  SDB_ASSIGN_OR_RETURN(auto reader, VolumeReader::Open(volume));
  std::unique_ptr<VolumeReader> mask;
  if (options.mask) {
    SDB_ASSIGN_OR_RETURN(mask, VolumeReader::Open(*options.mask));
  }
  Updater<D> updater(h, volume, *reader, mask.get(), box, options, start);
  SDB_RETURN_IF_ERROR(updater.ComputeErrors());

  lmdb::Env::Options o;
  o.read_only = false;
  o.sync_commits = true;  // the commit is the update: durable when it returns
  SDB_ASSIGN_OR_RETURN(auto env, lmdb::Env::Open(path, o));
  uint64_t growths = 0;
  while (true) {
    SparseUpdateReport report;
    bool map_full = false;
    int rc = MDB_SUCCESS;
    {
      SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/false));
      const Status s = updater.Apply(txn, &report, &map_full);
      if (!s.ok() && !map_full) return s;  // the transaction aborts: nothing written
      if (!map_full) {
        rc = txn.CommitCode();
        if (rc != MDB_SUCCESS && rc != MDB_MAP_FULL) return env->FromCode(rc, "commit");
        map_full = rc == MDB_MAP_FULL;
      }
    }
    if (!map_full) {
      report.map_growths = growths;
      report.seconds = SecondsSince(start);
      return report;
    }
    // Nothing of this attempt was kept: double the map and redo it.
    SDB_RETURN_IF_ERROR(env->SetMapBytes(2 * env->map_bytes()));
    ++growths;
  }
}

}  // namespace

Result<SparseUpdateReport> UpdateSparseStore(const std::string& path, const VolumeInfo& volume,
                                             const GridBox& box,
                                             const SparseUpdateOptions& options) {
  const Clock::time_point start = Clock::now();
  SparseHeader h;
  {
    // Checks the store; closed again before the writer opens it (LMDB
    // wants one environment per file and process).
    SDB_ASSIGN_OR_RETURN(auto store, SparseStore::Open(path));
    h = store->header();
  }
  const int d = h.dimension;
  const VoxelType type = StoredVoxelType(volume, options.mask.has_value());
  bool same = volume.dimension == d && type == h.voxel_type;
  for (int c = 0; c < d && same; ++c) same = volume.dims[c] == h.dims[c];
  if (!same) {
    return Status::InvalidArgument(fmt::format(
        "{} is {}D {} of {}{}, but the store {} holds {}D {} of {}", volume.description,
        volume.dimension, VoxelTypeName(volume.type), FormatDims(volume.dimension, volume.dims),
        options.mask      ? " (masked: float32)"
        : volume.scaled() ? " (scaled: " + FormatScaling(volume) + ")"
                          : "",
        path, d, VoxelTypeName(h.voxel_type),
        FormatDims(d, h.dims)));
  }
  if (options.mask) {
    SDB_RETURN_IF_ERROR(CheckMaskGrid(*options.mask, d, h.dims, "the store " + path + " holds"));
  }
  for (int c = 0; c < d; ++c) {
    if (box.lo[c] < 0 || box.lo[c] > box.hi[c] || box.hi[c] >= int64_t{h.dims[c]}) {
      return Status::InvalidArgument(fmt::format(
          "the box [{}, {}] along axis {} is not inside the grid's 0..{}", box.lo[c], box.hi[c],
          "xyzt"[c], h.dims[c] - 1));
    }
  }
  if (d == 3) return Update<3>(path, h, volume, box, options, start);
  return Update<4>(path, h, volume, box, options, start);
}

}  // namespace simplexdb
