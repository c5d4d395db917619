// Internals of query/mesh_io.cc, for its tests: WriteVtu with its knobs.
//
// Thread safety, lifetimes and errors: as WriteVtu (query/mesh_io.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "query/mesh_io.h"
#include "util/status.h"

namespace simplexdb::internal {

struct VtuOptions {
  // Uncompressed bytes per zlib block (the header's second word). VTK's
  // own writer uses 32 KiB; see kVtuBlockBytes in mesh_io.cc for ours.
  // REQUIRES: a positive multiple of 8, so no word of any array straddles
  // two blocks (VTK byte-swaps block by block on big-endian readers).
  size_t block_bytes;
  // zlib level, 1 (fastest) to 9.
  int level;
  // Connectivity and offsets are Int32 when the point count and 4 * cells
  // are both at most this, else Int64. INT32_MAX but in tests.
  uint64_t int32_limit;
  // Threads compressing blocks; 0: one per hardware thread.
  int threads;
};

// The options WriteVtu uses.
VtuOptions DefaultVtuOptions();

Status WriteVtu(const TetMeshData& mesh, const std::string& path, const VtuOptions& options);

}  // namespace simplexdb::internal
