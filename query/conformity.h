// CheckConformity: whether a list of simplices is a conforming mesh of the
// whole domain, checked from geometry alone (not from the hierarchy's
// cluster tables), so it can judge any algorithm's output, or a mesh a user
// brings as a list of codes.
//
// A list passes when
//   - it partitions the domain: no code repeats or contains another, and
//     the volumes (each level halves) add up to the domain's;
//   - every face of every simplex is shared by exactly two simplices with
//     the same D vertices (no hanging vertex: a face split on one side shows
//     as faces used once), except faces on the boundary of the domain, used
//     once.
//
// Cost: O(n log n) time and (D+1) * n faces of D packed vertices in memory
// (about 1.2 GB for the 12.6 million tetrahedra of a 129^3 grid).
//
// Thread safety: pure function; any number of calls at once.
//
// Lifetimes: the span is read during the call only; the report is a value.
//
// Errors: none reported as a Status. Whatever is wrong with the list
// (invalid codes included) gives ok == false and the first problem found in
// `problem`. std::bad_alloc when the faces do not fit in memory.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "hierarchy/simplex_code.h"

namespace simplexdb {

struct ConformityReport {
  bool ok = false;
  uint64_t simplices = 0;
  uint64_t interior_faces = 0;
  uint64_t boundary_faces = 0;
  std::string problem;  // empty when ok: the first thing found wrong
};

template <int D>
ConformityReport CheckConformity(std::span<const SimplexCode<D>> simplices);

}  // namespace simplexdb
