// Checks an LMDB data file's structure before LMDB is trusted with it.
//
// LMDB reads its file through a memory map and believes what the pages say:
// it checks the meta pages' magic and version and that a page number is at
// most the last page, and nothing else. A damaged page size divides by
// zero, a root of page 0 or 1 trips an assertion (abort), a node offset or a
// value size past the end of the file faults (SIGBUS or SIGSEGV) in LMDB or
// in the caller reading the value. So the stores check the file with pread
// first, the way LMDB will read it:
//
//   CheckMetas   both meta pages (LMDB reads both at open): page number,
//                flags, magic, version, page size (a power of two from
//                4 KiB to 32 KiB, as LMDB writes), the flags SimplexDB's
//                files have, each database record (root, depth, counts),
//                last page, and the file's size against the pages the meta
//                counts. Returns the meta LMDB will use (the larger
//                transaction id).
//   CheckPages   every page reachable from that meta, once each: the free
//                database, the main database and every named database in it
//                (the files hold no duplicate-key databases, so sub-pages,
//                LEAF2 pages and duplicate nodes are damage). Per page: its
//                number, its kind for its depth, the header's bounds, every
//                node inside the page, keys in strictly increasing order and
//                within the range the parent's separators give, every
//                overflow run in the file, of the right kind and length, not
//                shared; per database: the depth and the branch, leaf,
//                overflow and entry counts its record states; free-page
//                lists naming pages of the file that no tree uses.
//
// What passes both is safe for LMDB's read path and for a reader of its
// values: every page it can reach, every node and every value lies inside
// the file. The content of keys and values is the stores' own business
// (their checksums).
//
// Cost: CheckMetas reads two pages; CheckPages reads every branch and leaf
// page and the first page of every overflow run (free-page lists whole).
//
// Errors: Corruption "<name>: damaged LMDB file: <where>: <what>" for
// damage ("<name>: truncated: ..." for a file shorter than its pages);
// InvalidArgument when the file is not an LMDB file at all (shorter than a
// meta page, or meta page 0 without LMDB's magic); NotSupported for another
// LMDB data version; IOError when reading fails.
//
// Thread safety: pure functions of the file's bytes. The pages a meta
// reaches do not change while a read transaction on that meta is open
// (LMDB's copy-on-write), so a caller that checks pages concurrently with
// writers holds one.
#pragma once

#include <cstdint>
#include <string>

#include "util/status.h"

namespace simplexdb::lmdb {

struct MetaSummary {
  uint32_t page_size = 0;
  uint64_t last_page = 0;  // the highest page number in use
  uint64_t txnid = 0;      // the transaction that wrote the meta
};

// `fd` is open for reading on the file `name` names in messages.
Result<MetaSummary> CheckMetas(int fd, const std::string& name);

// Walks every page reachable from the meta of transaction `txnid`, which
// one of the two meta pages holds; NotFound when neither does any more (two
// commits since: the caller retries with a fresh transaction).
// REQUIRES: CheckMetas passed.
Status CheckPages(int fd, const std::string& name, uint64_t txnid);

}  // namespace simplexdb::lmdb
