#include "storage/tri/tri_leaf_store.h"

#include <sys/stat.h>

#include <cassert>
#include <string>
#include <string_view>
#include <type_traits>

#include "storage/io/lmdb.h"

namespace simplexdb {

namespace {

constexpr std::string_view kFormat = "simplexdb tri-leaf-store 1";

template <Polyhedron P>
constexpr std::string_view SolidName() {
  return P == Polyhedron::kIcosahedron  ? "icosahedron"
         : P == Polyhedron::kOctahedron ? "octahedron"
                                        : "tetrahedron";
}

std::span<const uint8_t> Bytes(std::string_view s) {
  return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

// The largest key at most `key` in the cursor's database: MDB_SUCCESS with
// *found, or MDB_SUCCESS with !*found when every key is larger; otherwise
// LMDB's error.
int FloorKey(MDB_cursor* cursor, uint64_t key, uint64_t* out, bool* found) {
  const auto bytes = lmdb::KeyBytes(key);
  MDB_val k = lmdb::Val(bytes.data(), bytes.size()), v;
  int rc = mdb_cursor_get(cursor, &k, &v, MDB_SET_RANGE);
  if (rc == MDB_SUCCESS && lmdb::KeyValue(k) != key) {
    rc = mdb_cursor_get(cursor, &k, &v, MDB_PREV);
  } else if (rc == MDB_NOTFOUND) {
    rc = mdb_cursor_get(cursor, &k, &v, MDB_LAST);
  }
  *found = rc == MDB_SUCCESS;
  if (rc == MDB_NOTFOUND) return MDB_SUCCESS;
  if (rc == MDB_SUCCESS) *out = lmdb::KeyValue(k);
  return rc;
}

// The leaf holding `code` (itself or its ancestor) in `txn`: MDB_SUCCESS
// and *found, or MDB_SUCCESS and !*found when `code` is subdivided.
template <Polyhedron P>
int FindLeaf(MDB_txn* txn, MDB_dbi dbi, TriCode<P> code, TriCode<P>* leaf, bool* found) {
  MDB_cursor* cursor = nullptr;
  int rc = mdb_cursor_open(txn, dbi, &cursor);
  if (rc != MDB_SUCCESS) return rc;
  uint64_t key = 0;
  rc = FloorKey(cursor, code.key(), &key, found);
  mdb_cursor_close(cursor);
  if (rc != MDB_SUCCESS || !*found) return rc;
  *leaf = TriCode<P>::FromKey(key);
  *found = leaf->is_valid() && leaf->contains(code);
  return MDB_SUCCESS;
}

int PutKey(MDB_txn* txn, MDB_dbi dbi, uint64_t key) {
  const auto bytes = lmdb::KeyBytes(key);
  MDB_val k = lmdb::Val(bytes.data(), bytes.size()), v = lmdb::Val(nullptr, 0);
  return mdb_put(txn, dbi, &k, &v, 0);
}

int DeleteKey(MDB_txn* txn, MDB_dbi dbi, uint64_t key) {
  const auto bytes = lmdb::KeyBytes(key);
  MDB_val k = lmdb::Val(bytes.data(), bytes.size());
  return mdb_del(txn, dbi, &k, nullptr);
}

// Calls fn(key) for every key in [lo, hi], in order.
template <class Fn>
Status ScanKeys(lmdb::Txn& txn, MDB_dbi dbi, uint64_t lo, uint64_t hi, Fn fn) {
  SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, dbi));
  const auto bytes = lmdb::KeyBytes(lo);
  MDB_val k = lmdb::Val(bytes.data(), bytes.size()), v;
  int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_SET_RANGE);
  while (rc == MDB_SUCCESS && lmdb::KeyValue(k) <= hi) {
    SDB_RETURN_IF_ERROR(fn(lmdb::KeyValue(k)));
    rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT);
  }
  if (rc != MDB_SUCCESS && rc != MDB_NOTFOUND) return txn.env().FromCode(rc, "read leaves");
  return Status::OK();
}

}  // namespace

template <Polyhedron P>
template <class Edit>
Status TriLeafStore<P>::Write(const char* what, Edit edit) {
  if (read_only_) {
    return Status::InvalidArgument(path() + ": cannot " + what +
                                   ": the store was opened read-only");
  }
  for (;;) {
    SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/false));
    int rc = MDB_SUCCESS;
    SDB_RETURN_IF_ERROR(edit(txn.get(), &rc));
    if (rc == MDB_SUCCESS) rc = txn.CommitCode();
    if (rc == MDB_SUCCESS) return Status::OK();
    txn.Abort();
    if (rc != MDB_MAP_FULL) return env_->FromCode(rc, what);
    SDB_RETURN_IF_ERROR(env_->SetMapBytes(env_->map_bytes() * 2));
  }
}

static_assert(std::is_same_v<MDB_dbi, unsigned int>, "tri_leaf_store.h keeps an MDB_dbi");

template <Polyhedron P>
TriLeafStore<P>::TriLeafStore(std::unique_ptr<lmdb::Env> env, unsigned int leaves, bool read_only)
    : env_(std::move(env)), leaves_(leaves), read_only_(read_only) {}

template <Polyhedron P>
TriLeafStore<P>::~TriLeafStore() = default;

template <Polyhedron P>
const std::string& TriLeafStore<P>::path() const {
  return env_->path();
}

template <Polyhedron P>
Result<std::unique_ptr<TriLeafStore<P>>> TriLeafStore<P>::Create(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) == 0) {
    return Status::InvalidArgument(path + ": creating a leaf store: the file exists");
  }
  lmdb::Env::Options options;
  options.read_only = false;
  options.sync_commits = true;
  options.map_bytes = uint64_t{16} << 20;  // grows on demand (Write)
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> env, lmdb::Env::Open(path, options));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/false));
  SDB_ASSIGN_OR_RETURN(const MDB_dbi meta, txn.OpenDb("meta", /*create=*/true));
  SDB_ASSIGN_OR_RETURN(const MDB_dbi leaves, txn.OpenDb("leaves", /*create=*/true));
  SDB_RETURN_IF_ERROR(txn.Put(meta, Bytes("format"), Bytes(kFormat)));
  SDB_RETURN_IF_ERROR(txn.Put(meta, Bytes("polyhedron"), Bytes(SolidName<P>())));
  for (int f = 0; f < Code::kFaces; ++f) {
    const int rc = PutKey(txn.get(), leaves, Code::Face(f).key());
    if (rc != MDB_SUCCESS) return env->FromCode(rc, "write the base faces");
  }
  SDB_RETURN_IF_ERROR(txn.Commit());
  return std::unique_ptr<TriLeafStore>(new TriLeafStore(std::move(env), leaves, false));
}

template <Polyhedron P>
Result<std::unique_ptr<TriLeafStore<P>>> TriLeafStore<P>::Open(const std::string& path,
                                                               bool read_only) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    return Status::NotFound(path + ": opening a leaf store: no such file");
  }
  lmdb::Env::Options options;
  options.read_only = read_only;
  options.sync_commits = true;
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<lmdb::Env> env, lmdb::Env::Open(path, options));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env, /*read_only=*/true));
  const auto not_ours = [&](std::string_view why) {
    return Status::InvalidArgument(path + ": not a triangle leaf store of the " +
                                   std::string(SolidName<P>()) + ": " + std::string(why));
  };
  auto meta = txn.OpenDb("meta", false);
  if (!meta.ok()) return not_ours("no 'meta' database");
  bool found = false;
  SDB_ASSIGN_OR_RETURN(const auto format, txn.Get(*meta, Bytes("format"), &found));
  if (!found || std::string_view(reinterpret_cast<const char*>(format.data()), format.size()) !=
                    kFormat) {
    return not_ours("the format is not '" + std::string(kFormat) + "'");
  }
  SDB_ASSIGN_OR_RETURN(const auto solid, txn.Get(*meta, Bytes("polyhedron"), &found));
  const std::string_view name(reinterpret_cast<const char*>(solid.data()), solid.size());
  if (!found || name != SolidName<P>()) {
    return not_ours("it holds the " + std::string(name));
  }
  auto leaves = txn.OpenDb("leaves", false);
  if (!leaves.ok()) return not_ours("no 'leaves' database");
  const MDB_dbi dbi = *leaves;
  SDB_RETURN_IF_ERROR(txn.Commit());
  return std::unique_ptr<TriLeafStore>(new TriLeafStore(std::move(env), dbi, read_only));
}

template <Polyhedron P>
Status TriLeafStore<P>::Refine(Code code) {
  assert(code.is_valid());
  return Write("refine", [&](MDB_txn* txn, int* rc) -> Status {
    Code leaf;
    bool found = false;
    *rc = FindLeaf<P>(txn, leaves_, code, &leaf, &found);
    if (*rc != MDB_SUCCESS) return Status::OK();
    if (!found) {
      return Status::InvalidArgument(path() + ": refining " + code.ToString() +
                                     ": it is already subdivided");
    }
    if (leaf == code) return Status::OK();
    *rc = DeleteKey(txn, leaves_, leaf.key());
    for (int l = leaf.level() + 1; l <= code.level() && *rc == MDB_SUCCESS; ++l) {
      const Code on_path = code.ancestor(l);
      for (int t = 0; t < 4 && *rc == MDB_SUCCESS; ++t) {
        const Code child = on_path.parent().child(t);
        if (child != on_path || l == code.level()) *rc = PutKey(txn, leaves_, child.key());
      }
    }
    return Status::OK();
  });
}

template <Polyhedron P>
Status TriLeafStore<P>::Coarsen(Code code) {
  assert(code.is_valid());
  return Write("coarsen", [&](MDB_txn* txn, int* rc) -> Status {
    Code leaf;
    bool found = false;
    *rc = FindLeaf<P>(txn, leaves_, code, &leaf, &found);
    if (*rc != MDB_SUCCESS || (found && leaf == code)) return Status::OK();
    if (found) {
      return Status::InvalidArgument(path() + ": coarsening " + code.ToString() +
                                     ": it lies inside the leaf " + leaf.ToString());
    }
    MDB_cursor* cursor = nullptr;
    *rc = mdb_cursor_open(txn, leaves_, &cursor);
    if (*rc != MDB_SUCCESS) return Status::OK();
    const auto bytes = lmdb::KeyBytes(code.range_min());
    MDB_val k = lmdb::Val(bytes.data(), bytes.size()), v;
    *rc = mdb_cursor_get(cursor, &k, &v, MDB_SET_RANGE);
    while (*rc == MDB_SUCCESS && lmdb::KeyValue(k) <= code.range_max()) {
      *rc = mdb_cursor_del(cursor, 0);
      // Search again rather than trust the cursor's position after a
      // delete: O(log n) per leaf removed.
      k = lmdb::Val(bytes.data(), bytes.size());
      if (*rc == MDB_SUCCESS) *rc = mdb_cursor_get(cursor, &k, &v, MDB_SET_RANGE);
    }
    mdb_cursor_close(cursor);
    if (*rc == MDB_NOTFOUND) *rc = MDB_SUCCESS;  // deleted up to the last key
    if (*rc == MDB_SUCCESS) *rc = PutKey(txn, leaves_, code.key());
    return Status::OK();
  });
}

template <Polyhedron P>
Result<TriCode<P>> TriLeafStore<P>::LeafContaining(Code code) const {
  assert(code.is_valid());
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  Code leaf;
  bool found = false;
  const int rc = FindLeaf<P>(txn.get(), leaves_, code, &leaf, &found);
  if (rc != MDB_SUCCESS) return env_->FromCode(rc, "find a leaf");
  if (!found) {
    return Status::NotFound(path() + ": " + code.ToString() + " is subdivided: no leaf holds it");
  }
  return leaf;
}

template <Polyhedron P>
Result<TriCode<P>> TriLeafStore<P>::LeafAt(LatLng point) const {
  return LeafContaining(LatLngToCode<P>(point, Code::kMaxLevel));
}

template <Polyhedron P>
Result<TriSizedNeighbor<P>> TriLeafStore<P>::Neighbor(Code leaf, TriDirection dir) const {
  assert(leaf.is_valid());
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  bool is_leaf = false;
  SDB_RETURN_IF_ERROR(txn.Get(leaves_, lmdb::KeyBytes(leaf.key()), &is_leaf).status());
  if (!is_leaf) {
    return Status::InvalidArgument(path() + ": " + leaf.ToString() + " is not a leaf");
  }
  const Code q = TriNeighbor(leaf, dir);
  Code holder;
  bool found = false;
  const int rc = FindLeaf<P>(txn.get(), leaves_, q, &holder, &found);
  if (rc != MDB_SUCCESS) return env_->FromCode(rc, "find a neighbor");
  if (!found) return TriSizedNeighbor<P>{q, TriNeighborSize::kSmaller};
  return TriSizedNeighbor<P>{holder,
                             holder == q ? TriNeighborSize::kEqual : TriNeighborSize::kLarger};
}

template <Polyhedron P>
Result<std::vector<TriCode<P>>> TriLeafStore<P>::LeavesUnder(Code under) const {
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  std::vector<Code> out;
  SDB_RETURN_IF_ERROR(
      ScanKeys(txn, leaves_, under.range_min(), under.range_max(), [&](uint64_t key) {
        out.push_back(Code::FromKey(key));
        return Status::OK();
      }));
  return out;
}

template <Polyhedron P>
Result<std::vector<TriCode<P>>> TriLeafStore<P>::Leaves() const {
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  std::vector<Code> out;
  SDB_RETURN_IF_ERROR(ScanKeys(txn, leaves_, 0, ~uint64_t{0}, [&](uint64_t key) {
    out.push_back(Code::FromKey(key));
    return Status::OK();
  }));
  return out;
}

template <Polyhedron P>
Result<uint64_t> TriLeafStore<P>::LeafCount() const {
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  MDB_stat stat_info{};
  const int rc = mdb_stat(txn.get(), leaves_, &stat_info);
  if (rc != MDB_SUCCESS) return env_->FromCode(rc, "count leaves");
  return static_cast<uint64_t>(stat_info.ms_entries);
}

// The leaves in key order tile the sphere exactly when each is the first
// leaf of what the previous ones left uncovered: a descendant of the next
// uncovered triangle along its 00 children, and the next uncovered
// triangle after it is the next sibling of its last ancestor that has one.
template <Polyhedron P>
Status TriLeafStore<P>::Verify() const {
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*env_, /*read_only=*/true));
  Code next = Code::Face(0);
  bool done = false;
  SDB_RETURN_IF_ERROR(ScanKeys(txn, leaves_, 0, ~uint64_t{0}, [&](uint64_t key) -> Status {
    const Code c = Code::FromKey(key);
    const auto bad = [&](std::string_view why) {
      return Status::Corruption(path() + ": leaf key " + std::to_string(key) + " (" +
                                (c.is_valid() ? c.ToString() : "invalid") +
                                "): " + std::string(why));
    };
    if (!c.is_valid()) return bad("not a triangle code of the " + std::string(SolidName<P>()));
    if (done) return bad("after the last face was covered");
    const uint64_t below = c.level() >= next.level()
                               ? c.path() & ((uint64_t{1} << 2 * (c.level() - next.level())) - 1)
                               : 1;
    if (c.level() < next.level() || c.ancestor(next.level()) != next || below != 0) {
      return bad("overlaps or leaves a gap before it: expected " + next.ToString() +
                 " or its first descendant");
    }
    Code x = c;
    while (x.level() > 0 && x.child_type() == 3) x = x.parent();
    if (x.level() > 0) {
      next = x.parent().child(x.child_type() + 1);
    } else if (x.face() + 1 < Code::kFaces) {
      next = Code::Face(x.face() + 1);
    } else {
      done = true;
    }
    return Status::OK();
  }));
  if (!done) {
    return Status::Corruption(path() + ": the leaves leave " + next.ToString() +
                              " and what follows it uncovered");
  }
  return Status::OK();
}

template class TriLeafStore<Polyhedron::kIcosahedron>;
template class TriLeafStore<Polyhedron::kOctahedron>;
template class TriLeafStore<Polyhedron::kTetrahedron>;

}  // namespace simplexdb
