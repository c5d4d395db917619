#include "storage/sparse/sparse_update.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <map>
#include <span>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "storage/io/file.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"
#include "storage/sparse/sparse_store.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The volume outside `box` against the store, a chunk of rows at a time:
// each value within the store's tolerance of what the store reads there.
template <int D>
Status CompareOutsideBox(const SparseStore& store, const VolumeInfo& volume, const GridBox& box,
                         const SparseUpdateOptions& options, Clock::time_point start) {
  const SparseHeader& h = store.header();
  SparseStore::Reader<D> reader(store);
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<VolumeReader> in, VolumeReader::Open(volume));
  const uint64_t count = volume.voxel_count();
  constexpr uint64_t kChunk = uint64_t{1} << 20;
  std::vector<double> values(std::min(kChunk, count));
  std::array<int64_t, D> p{};
  for (uint64_t first = 0; first < count; first += kChunk) {
    const uint64_t n = std::min(kChunk, count - first);
    SDB_RETURN_IF_ERROR(in->Read(first, n, values.data()));
    SDB_RETURN_IF_ERROR(CheckStorableValues(volume, first, values.data(), n));
    for (uint64_t i = 0; i < n; ++i) {
      uint64_t rest = first + i;
      bool inside = true;
      for (int a = 0; a < D; ++a) {
        p[a] = static_cast<int64_t>(rest % h.dims[a]);
        rest /= h.dims[a];
        inside = inside && p[a] >= box.lo[a] && p[a] <= box.hi[a];
      }
      if (inside) continue;
      double v = values[i];
      if (h.voxel_type == VoxelType::kF32) v = static_cast<float>(v);
      SDB_ASSIGN_OR_RETURN(const double stored, reader.Field(p));
      if (!(std::abs(v - stored) <= h.tolerance)) {
        std::string at;
        for (int a = 0; a < D; ++a) at += (a ? "," : "") + std::to_string(p[a]);
        return Status::InvalidArgument(fmt::format(
            "{}: the value at grid point ({}) is {:.9g}, the store {} holds {:.9g} (tolerance "
            "{:.6g}): the volume differs outside --box; widen the box or import it again",
            volume.description, at, v, store.path(), stored, h.tolerance));
      }
    }
    if (options.progress) {
      options.progress(BuildProgress{"compare", first + n, count, SecondsSince(start)});
    }
  }
  return Status::OK();
}

// Every key and value of database `dbi` in key order, through `f(key,
// value)` (the spans valid during the call).
template <class F>
Status ForEachEntry(lmdb::Txn& txn, MDB_dbi dbi, F&& f) {
  SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, dbi));
  MDB_val k, v;
  int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST);
  for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    SDB_RETURN_IF_ERROR(f(std::span<const uint8_t>(static_cast<const uint8_t*>(k.mv_data), k.mv_size),
                          std::span<const uint8_t>(static_cast<const uint8_t*>(v.mv_data), v.mv_size)));
  }
  if (rc != MDB_NOTFOUND) return txn.env().FromCode(rc, "reading its blocks");
  return Status::OK();
}

}  // namespace

Result<SparseUpdateReport> UpdateSparseStore(const std::string& path, const VolumeInfo& volume,
                                             const GridBox& box,
                                             const SparseUpdateOptions& options) {
  const Clock::time_point start = Clock::now();
  SparseHeader old_header;
  {
    SDB_ASSIGN_OR_RETURN(std::unique_ptr<SparseStore> store, SparseStore::Open(path, {}));
    const SparseHeader& h = store->header();
    bool same_grid = volume.dimension == h.dimension;
    for (int a = 0; same_grid && a < h.dimension; ++a) same_grid = volume.dims[a] == h.dims[a];
    const VoxelType type = StoredVoxelType(volume, false);
    if (!same_grid || type != h.voxel_type) {
      std::array<uint32_t, 4> dims{};
      std::copy(volume.dims.begin(), volume.dims.end(), dims.begin());
      return Status::InvalidArgument(fmt::format(
          "{}: a {}D {} volume of {}; the store {} is {}D {} of {}: update takes the grid and "
          "voxel type the store was imported from",
          volume.description, volume.dimension, VoxelTypeName(type),
          fmt::join(std::span(dims.data(), volume.dimension), "x"), path, h.dimension,
          VoxelTypeName(h.voxel_type), fmt::join(std::span(h.dims.data(), h.dimension), "x")));
    }
    for (int a = 0; a < h.dimension; ++a) {
      if (box.lo[a] < 0 || box.lo[a] > box.hi[a] || box.hi[a] >= h.dims[a]) {
        return Status::InvalidArgument(fmt::format(
            "box axis {}: {} .. {} is not inside the grid's 0 .. {}", a, box.lo[a], box.hi[a],
            h.dims[a] - 1));
      }
    }
    SDB_RETURN_IF_ERROR(h.dimension == 3 ? CompareOutsideBox<3>(*store, volume, box, options, start)
                                         : CompareOutsideBox<4>(*store, volume, box, options, start));
    old_header = h;
  }

  // The new store, whole, beside the old one.
  const TemporaryFile scratch(path, "update");
  SparseBuildOptions build;
  build.tolerance = old_header.tolerance;
  build.quantization = old_header.quantization;
  build.block_bits = old_header.block_bits;
  build.threads = options.threads;
  build.memory_bytes = options.memory_bytes;
  build.progress = options.progress;
  // The store keeps its placement: an update replaces values in a box, and
  // its input (often raw) may know no spacing or origin.
  VolumeInfo placed = volume;
  placed.spacing = old_header.spacing;
  placed.origin = old_header.origin;
  SDB_ASSIGN_OR_RETURN(const SparseBuildReport built, BuildSparseStore(placed, scratch.path(), build));

  // Its blocks into the old store, in one write transaction.
  SparseUpdateReport report;
  report.header = built.header;
  lmdb::Env::Options new_options;
  new_options.name = path;
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> fresh, lmdb::Env::Open(scratch.path(), new_options));
  lmdb::Env::Options old_options;
  old_options.read_only = false;
  old_options.sync_commits = true;
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> env, lmdb::Env::Open(path, old_options));
  // Room for every new block besides the old ones (pages freed in this
  // transaction are not reused by it).
  std::error_code size_error;
  const uint64_t old_bytes = std::filesystem::file_size(path, size_error);
  SDB_RETURN_IF_ERROR(env->SetMapBytes(std::max(env->map_bytes(), old_bytes + 2 * built.file_bytes +
                                                                      (uint64_t{64} << 20))));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn in, lmdb::Txn::Begin(*fresh, /*read_only=*/true));
  SDB_ASSIGN_OR_RETURN(const MDB_dbi in_db, in.OpenDb(nullptr, false));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/false));
  SDB_ASSIGN_OR_RETURN(const MDB_dbi db, txn.OpenDb(nullptr, false));
  // Entries are blocks' parts (sparse_format.h), cut where each file's
  // pages end: blocks are compared whole. A changed block's old parts are
  // deleted and the new ones put; the report counts blocks.
  std::map<uint64_t, uint32_t> old_parts, new_parts;
  const auto count_parts = [](const std::string& file, std::map<uint64_t, uint32_t>* parts) {
    return [file, parts](std::span<const uint8_t> key, std::span<const uint8_t>) -> Status {
      uint64_t b = 0;
      uint32_t part = 0;
      if (IsSparseHeaderKey(key)) return Status::OK();
      if (!ParseSparseKey(key, &b, &part)) {
        return Status::Corruption(file + ": a key of " + std::to_string(key.size()) + " bytes");
      }
      ++(*parts)[b];
      return Status::OK();
    };
  };
  SDB_RETURN_IF_ERROR(ForEachEntry(txn, db, count_parts(path, &old_parts)));
  SDB_RETURN_IF_ERROR(ForEachEntry(in, in_db, count_parts(scratch.path(), &new_parts)));
  const auto remove = [&](uint64_t b, uint32_t parts) -> Status {
    for (uint32_t part = 0; part < parts; ++part) {
      auto k = SparseKey(b, part);
      MDB_val key{k.size(), k.data()};
      if (const int rc = mdb_del(txn.get(), db, &key, nullptr); rc != MDB_SUCCESS) {
        return env->FromCode(rc, "deleting block " + std::to_string(b));
      }
    }
    return Status::OK();
  };
  std::vector<uint8_t> old_value, new_value;
  for (const auto& [b, parts] : new_parts) {
    SDB_RETURN_IF_ERROR(ReadSparseBlockValue(in, in_db, b, scratch.path(), &new_value).status());
    const auto old = old_parts.find(b);
    if (old != old_parts.end()) {
      SDB_RETURN_IF_ERROR(ReadSparseBlockValue(txn, db, b, path, &old_value).status());
      if (old_value == new_value) {
        ++report.blocks_unchanged;
        continue;
      }
      SDB_RETURN_IF_ERROR(remove(b, old->second));
    }
    for (uint32_t part = 0; part < parts; ++part) {
      const auto key = SparseKey(b, part);
      bool found = false;
      SDB_ASSIGN_OR_RETURN(const std::span<const uint8_t> value, in.Get(in_db, key, &found));
      if (!found) return Status::Corruption(scratch.path() + ": block " + std::to_string(b) + " lost a part");
      SDB_RETURN_IF_ERROR(txn.Put(db, key, value));
    }
    ++report.blocks_written;
  }
  for (const auto& [b, parts] : old_parts) {
    if (new_parts.count(b)) continue;
    SDB_RETURN_IF_ERROR(remove(b, parts));
    ++report.blocks_deleted;
  }
  SDB_RETURN_IF_ERROR(txn.Put(db, kSparseHeaderKey, EncodeSparseHeader(built.header)));
  in.Abort();
  SDB_RETURN_IF_ERROR(txn.Commit());
  if (options.progress) {
    const uint64_t n = report.blocks_written + report.blocks_deleted;
    options.progress(BuildProgress{"write", n, n, SecondsSince(start)});
  }
  report.seconds = SecondsSince(start);
  return report;
}

}  // namespace simplexdb
