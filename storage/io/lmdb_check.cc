#include "storage/io/lmdb_check.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cstring>
#include <optional>
#include <string_view>
#include <vector>

#include "storage/io/file.h"

namespace simplexdb::lmdb {

namespace {

static_assert(std::endian::native == std::endian::little && sizeof(size_t) == 8,
              "the layout below is LMDB's on 64-bit little-endian machines");

// LMDB 0.9's on-disk layout (mdb.c): a page header of 16 bytes (page number
// u64; pad u16; flags u16; lower and upper bounds u16 each, or for an
// overflow run its page count u32), then the node offsets (u16 each); a
// node is 8 bytes (data size, or a branch's child page number, in lo, hi and
// for branches flags; flags u16; key size u16) then the key then the data.
constexpr uint32_t kHeader = 16;
constexpr uint32_t kNodeHeader = 8;
constexpr uint16_t kBranch = 0x01, kLeaf = 0x02, kOverflow = 0x04, kMeta = 0x08, kDirty = 0x10;
constexpr uint16_t kBigData = 0x01, kSubData = 0x02;
constexpr uint32_t kMagic = 0xBEEFC0DE;
constexpr uint32_t kDataVersion = 1;
constexpr uint64_t kInvalidPage = ~uint64_t{0};
constexpr uint16_t kIntegerKey = 0x08, kNoSubdir = 0x4000;
constexpr int kMaxDepth = 32;  // LMDB's cursor stack
constexpr uint32_t kDbRecord = 48;
constexpr uint32_t kMetaBytes = kHeader + 136;

template <class T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

struct DbRecord {
  uint16_t flags = 0, depth = 0;
  uint64_t branch_pages = 0, leaf_pages = 0, overflow_pages = 0, entries = 0;
  uint64_t root = kInvalidPage;
};

DbRecord ParseDb(const uint8_t* p) {
  DbRecord d;
  d.flags = Load<uint16_t>(p + 4);
  d.depth = Load<uint16_t>(p + 6);
  d.branch_pages = Load<uint64_t>(p + 8);
  d.leaf_pages = Load<uint64_t>(p + 16);
  d.overflow_pages = Load<uint64_t>(p + 24);
  d.entries = Load<uint64_t>(p + 32);
  d.root = Load<uint64_t>(p + 40);
  return d;
}

struct Meta {
  uint16_t page_flags = 0;
  uint64_t page_number = 0;
  uint32_t magic = 0, version = 0, page_size = 0;
  uint16_t env_flags = 0;
  DbRecord free_db, main_db;
  uint64_t last_page = 0, txnid = 0;
};

Meta ParseMeta(const uint8_t* p) {
  Meta m;
  m.page_number = Load<uint64_t>(p);
  m.page_flags = Load<uint16_t>(p + 10);
  m.magic = Load<uint32_t>(p + 16);
  m.version = Load<uint32_t>(p + 20);
  m.page_size = Load<uint32_t>(p + 40);  // the free database record's pad
  m.env_flags = Load<uint16_t>(p + 44);  // and its flags
  m.free_db = ParseDb(p + 40);
  m.main_db = ParseDb(p + 88);
  m.last_page = Load<uint64_t>(p + 136);
  m.txnid = Load<uint64_t>(p + 144);
  return m;
}

Status ReadAt(int fd, const std::string& name, uint8_t* out, size_t n, uint64_t offset,
              std::string_view what) {
  size_t done = 0;
  while (done < n) {
    const ssize_t r = pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return StatusFromErrno(errno, name, "read " + std::string(what));
    }
    if (r == 0) {
      return Status::Corruption(name + ": damaged LMDB file: " + std::string(what) +
                                " is past the end of the file");
    }
    done += static_cast<size_t>(r);
  }
  return Status::OK();
}

std::string PageName(uint64_t pgno) { return "page " + std::to_string(pgno); }

// What is wrong with a database record that says its tree has `flags` in a
// file of pages up to `last_page` (empty: nothing).
std::string RecordProblem(const DbRecord& d, uint16_t flags, uint64_t last_page) {
  if (d.flags != flags) return "flags " + std::to_string(d.flags);
  if (d.root == kInvalidPage) {
    if ((d.depth | d.branch_pages | d.leaf_pages | d.overflow_pages | d.entries) != 0) {
      return "empty, yet it counts pages or entries";
    }
    return {};
  }
  if (d.root < 2 || d.root > last_page) {
    return "root page " + std::to_string(d.root) + " (pages 2 to " + std::to_string(last_page) +
           " hold data)";
  }
  if (d.depth < 1 || d.depth > kMaxDepth) return "depth " + std::to_string(d.depth);
  return {};
}

// Corruption unless the file holds every page meta `m` counts.
Status CheckFileSize(int fd, const std::string& name, const Meta& m) {
  struct stat st {};
  if (fstat(fd, &st) != 0) return StatusFromErrno(errno, name, "read the file's size");
  if (m.last_page > (uint64_t{1} << 48) ||
      static_cast<uint64_t>(st.st_size) < (m.last_page + 1) * m.page_size) {
    return Status::Corruption(name + ": truncated: " + std::to_string(st.st_size) +
                              " bytes, but its meta page counts " + std::to_string(m.last_page + 1) +
                              " pages of " + std::to_string(m.page_size) + " bytes");
  }
  return Status::OK();
}

// Reads and checks meta page `slot` at `offset` (LMDB reads meta 1 at meta
// 0's page size).
Result<Meta> ReadMeta(int fd, const std::string& name, int slot, uint64_t offset) {
  uint8_t buf[kMetaBytes];
  const std::string what = "meta page " + std::to_string(slot);
  {
    // A file shorter than a meta page: LMDB reads it as not LMDB at all.
    struct stat st {};
    if (fstat(fd, &st) != 0) return StatusFromErrno(errno, name, "read the file's size");
    if (static_cast<uint64_t>(st.st_size) < offset + kMetaBytes) {
      if (slot == 0) return Status::InvalidArgument(name + ": not an LMDB file (shorter than a meta page)");
      return Status::Corruption(name + ": damaged LMDB file: truncated before " + what);
    }
  }
  SDB_RETURN_IF_ERROR(ReadAt(fd, name, buf, sizeof buf, offset, what));
  const Meta m = ParseMeta(buf);
  const auto bad = [&](const std::string& why) {
    return Status::Corruption(name + ": damaged LMDB file: " + what + ": " + why);
  };
  if (m.magic != kMagic) {
    if (slot == 0) return Status::InvalidArgument(name + ": not an LMDB file (no LMDB magic number)");
    return bad("no LMDB magic number");
  }
  if (!(m.page_flags & kMeta)) return bad("not marked as a meta page");
  if (m.version != kDataVersion) {
    return Status::NotSupported(name + ": LMDB data version " + std::to_string(m.version) +
                                ", this build reads version " + std::to_string(kDataVersion));
  }
  if (m.page_flags != kMeta || m.page_number != static_cast<uint64_t>(slot)) {
    return bad("page header says page " + std::to_string(m.page_number) + ", flags " +
               std::to_string(m.page_flags));
  }
  if (!std::has_single_bit(m.page_size) || m.page_size < 4096 || m.page_size > 32768) {
    return bad("page size " + std::to_string(m.page_size) + " (expected a power of two from 4096 to 32768)");
  }
  if ((m.env_flags & ~kNoSubdir) != kIntegerKey) {
    return bad("environment flags " + std::to_string(m.env_flags) + " (SimplexDB writes " +
               std::to_string(kIntegerKey | kNoSubdir) + ")");
  }
  if (m.last_page < 1) return bad("last page " + std::to_string(m.last_page));
  // The free database's flags are the environment's (the same bytes).
  if (const std::string p = RecordProblem(m.free_db, m.env_flags, m.last_page); !p.empty()) {
    return bad("free database record: " + p);
  }
  if (const std::string p = RecordProblem(m.main_db, 0, m.last_page); !p.empty()) {
    return bad("main database record: " + p);
  }
  return m;
}

struct ReadMetas {
  Meta meta[2];
  int slot = 0;  // the one LMDB reads: the larger transaction id (meta 0 on a tie)
};

Result<ReadMetas> ReadBothMetas(int fd, const std::string& name) {
  ReadMetas r;
  SDB_ASSIGN_OR_RETURN(r.meta[0], ReadMeta(fd, name, 0, 0));
  SDB_ASSIGN_OR_RETURN(r.meta[1], ReadMeta(fd, name, 1, r.meta[0].page_size));
  if (r.meta[1].page_size != r.meta[0].page_size) {
    return Status::Corruption(name + ": damaged LMDB file: the meta pages disagree on the page size (" +
                              std::to_string(r.meta[0].page_size) + ", " +
                              std::to_string(r.meta[1].page_size) + ")");
  }
  r.slot = r.meta[0].txnid < r.meta[1].txnid ? 1 : 0;
  return r;
}

// The walk of CheckPages.
class Walker {
 public:
  Walker(int fd, const std::string& name, const Meta& meta)
      : fd_(fd), name_(name), psize_(meta.page_size), last_(meta.last_page),
        seen_((meta.last_page >> 6) + 1, 0) {}

  // How a database's keys are ordered: LMDB's memcmp-then-length, or (the
  // free database) native 8-byte integers.
  enum class Keys { kBytes, kInteger };

  // Walks database `db` (named `what` in messages). The main database's
  // named databases go to *named; the free database's page lists to free_.
  Status Walk(const DbRecord& db, const std::string& what, Keys keys,
              std::vector<std::pair<std::string, DbRecord>>* named) {
    if (db.root == kInvalidPage) return Status::OK();
    db_ = &what;
    keys_ = keys;
    named_ = named;
    counts_ = DbRecord{};
    SDB_RETURN_IF_ERROR(WalkPage(db.root, kInvalidPage, 1, db.depth, std::nullopt, std::nullopt));
    const auto mismatch = [&](const char* of, uint64_t stated, uint64_t found) {
      return Bad(what + " database: its record counts " + std::to_string(stated) + " " + of +
                 ", the tree holds " + std::to_string(found));
    };
    if (counts_.branch_pages != db.branch_pages) {
      return mismatch("branch pages", db.branch_pages, counts_.branch_pages);
    }
    if (counts_.leaf_pages != db.leaf_pages) return mismatch("leaf pages", db.leaf_pages, counts_.leaf_pages);
    if (counts_.overflow_pages != db.overflow_pages) {
      return mismatch("overflow pages", db.overflow_pages, counts_.overflow_pages);
    }
    if (counts_.entries != db.entries) return mismatch("entries", db.entries, counts_.entries);
    return Status::OK();
  }

  // Free-page lists: pages of the file that no tree uses, each listed once.
  Status CheckFreePages() {
    std::sort(free_.begin(), free_.end());
    for (size_t i = 0; i < free_.size(); ++i) {
      const uint64_t p = free_[i];
      if (p < 2 || p > last_) {
        return Bad("the free-page list names " + PageName(p) + ", not a data page of the file");
      }
      if (i > 0 && free_[i - 1] == p) return Bad("the free-page list names " + PageName(p) + " twice");
      if (Seen(p)) return Bad("the free-page list names " + PageName(p) + ", which a tree uses");
    }
    return Status::OK();
  }

 private:
  Status Bad(const std::string& why) const {
    return Status::Corruption(name_ + ": damaged LMDB file: " + why);
  }
  Status BadPage(uint64_t pgno, const std::string& why) const {
    return Bad(PageName(pgno) + " (" + *db_ + " database): " + why);
  }
  bool Seen(uint64_t p) const { return (seen_[p >> 6] >> (p & 63)) & 1; }
  // Marks page `pgno`, which page `from` (kInvalidPage: the database's
  // record) points to.
  Status Mark(uint64_t pgno, uint64_t from) {
    const auto bad = [&](const std::string& why) {
      return from == kInvalidPage ? Bad("the " + *db_ + " database's root: " + why) : BadPage(from, why);
    };
    if (pgno < 2 || pgno > last_) {
      return bad("points to " + PageName(pgno) + " (pages 2 to " + std::to_string(last_) + " hold data)");
    }
    if (Seen(pgno)) return bad("points to " + PageName(pgno) + ", which something else points to too");
    seen_[pgno >> 6] |= uint64_t{1} << (pgno & 63);
    return Status::OK();
  }

  // Integer keys are 8 bytes each (checked before comparing).
  int Compare(std::string_view a, std::string_view b) const {
    if (keys_ == Keys::kInteger) {
      const uint64_t x = Load<uint64_t>(reinterpret_cast<const uint8_t*>(a.data()));
      const uint64_t y = Load<uint64_t>(reinterpret_cast<const uint8_t*>(b.data()));
      return x < y ? -1 : x > y ? 1 : 0;
    }
    const int c = std::memcmp(a.data(), b.data(), std::min(a.size(), b.size()));
    if (c != 0) return c;
    return a.size() < b.size() ? -1 : a.size() > b.size() ? 1 : 0;
  }

  // Page `pgno` (pointed to by `parent`) at `depth` of a tree of
  // `leaf_depth`, its keys in [lo, hi).
  Status WalkPage(uint64_t pgno, uint64_t parent, int depth, int leaf_depth,
                  const std::optional<std::string>& lo, const std::optional<std::string>& hi) {
    SDB_RETURN_IF_ERROR(Mark(pgno, parent));
    std::vector<uint8_t>& page = buffers_[static_cast<size_t>(depth)];  // one per level of the walk
    page.resize(psize_);
    SDB_RETURN_IF_ERROR(ReadAt(fd_, name_, page.data(), psize_, pgno * psize_, PageName(pgno)));
    const uint8_t* p = page.data();
    if (Load<uint64_t>(p) != pgno) {
      return BadPage(pgno, "its header says page " + std::to_string(Load<uint64_t>(p)));
    }
    const uint16_t flags = Load<uint16_t>(p + 10) & ~kDirty;
    const bool leaf = depth == leaf_depth;
    if (flags != (leaf ? kLeaf : kBranch)) {
      return BadPage(pgno, "flags " + std::to_string(flags) + " at depth " + std::to_string(depth) +
                               " of " + std::to_string(leaf_depth) + " (expected a " +
                               (leaf ? "leaf" : "branch") + ")");
    }
    const uint32_t lower = Load<uint16_t>(p + 12), upper = Load<uint16_t>(p + 14);
    if (lower < kHeader + 2 || lower > upper || upper > psize_ || (lower - kHeader) % 2 != 0) {
      return BadPage(pgno, "bounds " + std::to_string(lower) + ".." + std::to_string(upper));
    }
    const uint32_t n = (lower - kHeader) / 2;
    if (leaf) {
      ++counts_.leaf_pages;
    } else {
      ++counts_.branch_pages;
    }
    std::optional<std::string_view> previous;
    struct Child {
      uint64_t pgno;
      std::optional<std::string> lo;
    };
    std::vector<Child> children;
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t off = Load<uint16_t>(p + kHeader + 2 * i);
      const auto node = [i] { return "node " + std::to_string(i); };  // for messages
      if (off < upper || off + kNodeHeader > psize_) {
        return BadPage(pgno, node() + " at offset " + std::to_string(off) + ", outside the page's nodes (" +
                                 std::to_string(upper) + ".." + std::to_string(psize_) + ")");
      }
      const uint8_t* nd = p + off;
      const uint16_t nflags = Load<uint16_t>(nd + 4);
      const uint32_t ksize = Load<uint16_t>(nd + 6);
      if (off + kNodeHeader + ksize > psize_) return BadPage(pgno, node() + ": its key runs past the page");
      const std::string_view key(reinterpret_cast<const char*>(nd + kNodeHeader), ksize);
      // A branch's first key is not a key (LMDB never reads it).
      const bool keyed = leaf || i > 0;
      if (keyed) {
        if (keys_ == Keys::kInteger && ksize != 8) {
          return BadPage(pgno, node() + ": a key of " + std::to_string(ksize) + " bytes (expected 8)");
        }
        if (previous && Compare(*previous, key) >= 0) return BadPage(pgno, node() + ": keys out of order");
        if (lo && Compare(key, *lo) < 0) return BadPage(pgno, node() + ": a key below its separator");
        if (hi && Compare(key, *hi) >= 0) return BadPage(pgno, node() + ": a key past its separators");
        previous = key;
      }
      if (!leaf) {
        const uint64_t child = Load<uint16_t>(nd) | uint64_t{Load<uint16_t>(nd + 2)} << 16 |
                               uint64_t{nflags} << 32;
        children.push_back(Child{child, keyed ? std::optional<std::string>(key) : lo});
        continue;
      }
      ++counts_.entries;
      const uint32_t dsize = Load<uint16_t>(nd) | uint32_t{Load<uint16_t>(nd + 2)} << 16;
      const uint8_t* data = nd + kNodeHeader + ksize;
      const uint32_t data_off = off + kNodeHeader + ksize;
      if (nflags == kBigData) {
        if (data_off + 8 > psize_) return BadPage(pgno, node() + ": its overflow page runs past the page");
        SDB_RETURN_IF_ERROR(Overflow(pgno, node(), Load<uint64_t>(data), dsize));
        continue;
      }
      if (data_off + uint64_t{dsize} > psize_) {
        return BadPage(pgno, node() + ": its value runs past the page");
      }
      if (nflags == kSubData && named_ != nullptr) {
        if (dsize != kDbRecord) {
          return BadPage(pgno, node() + ": a database record of " + std::to_string(dsize) + " bytes");
        }
        named_->emplace_back(std::string(key), ParseDb(data));
        continue;
      }
      if (nflags != 0) return BadPage(pgno, node() + ": node flags " + std::to_string(nflags));
      if (keys_ == Keys::kInteger) {
        SDB_RETURN_IF_ERROR(FreeList(pgno, node(), data, dsize));
      }
    }
    if (!leaf) {
      if (depth >= leaf_depth) return BadPage(pgno, "a branch at the leaves' depth");
      for (size_t c = 0; c < children.size(); ++c) {
        const std::optional<std::string>& child_hi = c + 1 < children.size() ? children[c + 1].lo : hi;
        SDB_RETURN_IF_ERROR(
            WalkPage(children[c].pgno, pgno, depth + 1, leaf_depth, children[c].lo, child_hi));
      }
    }
    return Status::OK();
  }

  // The overflow run a leaf node's value is in.
  Status Overflow(uint64_t from, const std::string& node, uint64_t first, uint32_t dsize) {
    if (first < 2 || first > last_) {
      return BadPage(from, node + ": its value is on " + PageName(first) + ", not a data page");
    }
    uint8_t header[kHeader];
    SDB_RETURN_IF_ERROR(ReadAt(fd_, name_, header, kHeader, first * psize_, PageName(first)));
    const uint64_t needed = (kHeader - 1 + uint64_t{dsize}) / psize_ + 1;
    const uint32_t pages = Load<uint32_t>(header + 12);
    if (Load<uint64_t>(header) != first || (Load<uint16_t>(header + 10) & ~kDirty) != kOverflow ||
        pages < needed || first + pages - 1 > last_) {
      return BadPage(from, node + ": its value's " + PageName(first) +
                               " is not an overflow run of at least " + std::to_string(needed) +
                               " pages inside the file");
    }
    for (uint64_t q = first; q < first + pages; ++q) SDB_RETURN_IF_ERROR(Mark(q, from));
    counts_.overflow_pages += pages;
    if (keys_ == Keys::kInteger) {
      std::vector<uint8_t> list(dsize);
      SDB_RETURN_IF_ERROR(ReadAt(fd_, name_, list.data(), dsize, first * psize_ + kHeader, PageName(first)));
      return FreeList(from, node, list.data(), dsize);
    }
    return Status::OK();
  }

  // A free database value: a count, then that many page numbers.
  Status FreeList(uint64_t from, const std::string& node, const uint8_t* data, uint32_t dsize) {
    if (dsize < 8) return BadPage(from, node + ": a free-page list of " + std::to_string(dsize) + " bytes");
    const uint64_t count = Load<uint64_t>(data);
    if (count > (dsize - 8) / 8) {
      return BadPage(from, node + ": a free-page list of " + std::to_string(count) + " pages in " +
                               std::to_string(dsize) + " bytes");
    }
    for (uint64_t i = 0; i < count; ++i) free_.push_back(Load<uint64_t>(data + 8 + 8 * i));
    return Status::OK();
  }

  int fd_;
  const std::string& name_;
  uint64_t psize_, last_;
  std::vector<uint64_t> seen_;
  std::array<std::vector<uint8_t>, kMaxDepth + 1> buffers_;
  const std::string* db_ = nullptr;
  Keys keys_ = Keys::kBytes;
  std::vector<std::pair<std::string, DbRecord>>* named_ = nullptr;
  DbRecord counts_;
  std::vector<uint64_t> free_;
};

}  // namespace

Result<MetaSummary> CheckMetas(int fd, const std::string& name) {
  SDB_ASSIGN_OR_RETURN(const ReadMetas metas, ReadBothMetas(fd, name));
  const Meta& m = metas.meta[metas.slot];
  SDB_RETURN_IF_ERROR(CheckFileSize(fd, name, m));
  MetaSummary s;
  s.page_size = m.page_size;
  s.last_page = m.last_page;
  s.txnid = m.txnid;
  return s;
}

Status CheckPages(int fd, const std::string& name, uint64_t txnid) {
  SDB_ASSIGN_OR_RETURN(const ReadMetas metas, ReadBothMetas(fd, name));
  const Meta* m = metas.meta[0].txnid == txnid ? &metas.meta[0]
                  : metas.meta[1].txnid == txnid ? &metas.meta[1]
                                                 : nullptr;
  if (m == nullptr) {
    return Status::NotFound(name + ": transaction " + std::to_string(txnid) +
                            " is no longer the file's latest (a writer committed since)");
  }
  SDB_RETURN_IF_ERROR(CheckFileSize(fd, name, *m));
  Walker walker(fd, name, *m);
  SDB_RETURN_IF_ERROR(walker.Walk(m->free_db, "free", Walker::Keys::kInteger, nullptr));
  std::vector<std::pair<std::string, DbRecord>> named;
  SDB_RETURN_IF_ERROR(walker.Walk(m->main_db, "main", Walker::Keys::kBytes, &named));
  for (const auto& [db_name, record] : named) {
    const std::string what = "'" + db_name + "'";
    if (const std::string problem = RecordProblem(record, 0, m->last_page); !problem.empty()) {
      return Status::Corruption(name + ": damaged LMDB file: the record of database " + what + ": " +
                                problem);
    }
    SDB_RETURN_IF_ERROR(walker.Walk(record, what, Walker::Keys::kBytes, nullptr));
  }
  return walker.CheckFreePages();
}

}  // namespace simplexdb::lmdb
