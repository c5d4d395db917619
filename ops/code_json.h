// The JSON line `simplexdb codes` prints for a location code (the contract
// of DESIGN.md, read by outside checks), built here so the command and the
// Python package's simplexdb.codes() give the same objects. Keys in the
// contract's order: code, level, vertices, neighbors, parent, children,
// cluster.
//
// Thread safety: pure functions. Lifetimes: strings are returned by value.
// Errors: DescribeCode's InvalidArgument (below).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/tri_code.h"
#include "util/status.h"

namespace simplexdb {

// A lattice coordinate as a unit-cube coordinate, x / 2^kCoordBits<D>.
template <int D>
double UnitCoordinate(int32_t x) {
  return static_cast<double>(x) / static_cast<double>(kDomainSide<D>);
}

// The line for one code, as compact JSON text without a newline. For an
// HT/HP code: vertices in unit-cube coordinates (v1 first), neighbors across
// face types 1..D+1 (null on the domain boundary), parent (null for a
// root), children (null at the deepest level a key holds), cluster. For a
// triangle quadtree: vertices apex, left, right on the solid inscribed in
// the unit sphere, neighbors left, right, vertical, four children, an empty
// cluster. O(level).
std::string CodeJson(TetCode code);
std::string CodeJson(PentaCode code);
std::string CodeJson(IcosaCode code);
std::string CodeJson(OctaCode code);
std::string CodeJson(TetraCode code);

// The line for `text` read as a code of `hierarchy` ("ht", "hp",
// "tri-icosahedron", "tri-octahedron", "tri-tetrahedron"). InvalidArgument
// naming the valid hierarchies for another name, or the parser's for text
// that is not a code.
Result<std::string> DescribeCode(std::string_view hierarchy, std::string_view text);

}  // namespace simplexdb
