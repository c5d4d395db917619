// LOD criteria (seed sections 3.6 and 4.6; DESIGN.md "Queries"): which
// simplices of an extracted mesh are held to the error threshold.
//
// A simplex fails, and must be split, when its error bound exceeds the
// threshold and every criterion given applies to it:
//
//   box      the closed simplex meets the closed box (an exact test, not
//            bounding boxes: see SimplexMeetsBox);
//   iso      the isovalue lies in the simplex's vertex-value range widened by
//            the simplex's own error on both sides (the field may reach it
//            between the vertices: the bare range misses isosurfaces that
//            coarse simplices hide);
//   time     (HP) the pentatope meets the hyperplane t = T.
//
// With no box, iso or time the threshold is uniform. Coordinates here are the
// lattice's (hierarchy/geometry.h: grid point g of a domain of side 2^k is
// lattice point g * 2^(kCoordBits - k)); MakeCriteria converts from the
// input grid's own coordinates.
//
// Thread safety: values; the functions are pure.
//
// Lifetimes: everything is a value; Criteria copies what it needs from the
// spec.
//
// Errors: only MakeCriteria fails: InvalidArgument naming the value and
// what was expected (a threshold that is negative or not finite, a box of
// the wrong count of numbers or with a bound that is not finite or low >
// high, an isovalue or time that is not finite, a time on an HT). Box
// bounds beyond the grid are clamped, not refused. Applies and the
// geometric tests cannot fail.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hierarchy/geometry.h"
#include "util/status.h"

namespace simplexdb {

template <int D>
struct LatticeBox {
  std::array<int64_t, D> lo{}, hi{};  // closed: lo <= x <= hi on every axis
};

template <int D>
struct Criteria {
  double threshold = 0;  // absolute, in field units
  std::optional<LatticeBox<D>> box;
  std::optional<double> iso;
  std::optional<double> time;  // lattice units along the fourth axis (HP only)

  // Whether Applies() needs the simplex's vertices; the uniform threshold
  // needs only the error.
  bool needs_geometry() const { return box.has_value() || iso.has_value() || time.has_value(); }
  bool needs_values() const { return iso.has_value(); }
};

// Whether the closed simplex with vertices `v` meets the closed box. Exact
// (integer arithmetic in 128 bits) by the separating axis theorem: two
// convex polytopes are disjoint iff some facet normal of their Minkowski
// difference separates them. For a simplex and an axis-aligned box those
// normals are, for every set C of m axes, the normals (within the coordinates
// C, zero elsewhere) of the projections onto C of the simplex's faces with m
// vertices: m = 1 gives the axes (the bounding-box test), m = D the simplex's
// own facets. 25 candidate directions in 3D, 109 in 4D; most simplices are
// decided by the bounding boxes or a vertex inside the box first.
template <int D>
bool SimplexMeetsBox(const SimplexVertices<D>& v, const LatticeBox<D>& box);

// Whether `v` meets the hyperplane x[D-1] = t (its extent along the last axis
// holds t).
template <int D>
bool SimplexMeetsSlice(const SimplexVertices<D>& v, double t) {
  int32_t lo = v[0][D - 1], hi = lo;
  for (const auto& p : v) {
    lo = std::min(lo, p[D - 1]);
    hi = std::max(hi, p[D - 1]);
  }
  return lo <= t && t <= hi;
}

// Whether the criteria hold the simplex (vertices `v`, vertex values
// `values` when needs_values(), error bound `error`) to the threshold.
template <int D>
bool Applies(const Criteria<D>& c, const SimplexVertices<D>& v,
             const std::array<double, D + 1>* values, double error) {
  if (c.box && !SimplexMeetsBox<D>(v, *c.box)) return false;
  if (c.time && !SimplexMeetsSlice<D>(v, *c.time)) return false;
  if (c.iso) {
    const auto [lo, hi] = std::minmax_element(values->begin(), values->end());
    const double iso = *c.iso;
    if (iso < *lo - error || iso > *hi + error) return false;
  }
  return true;
}

// A threshold given as "7.3" (absolute) or "1%" (of the field range).
struct Amount {
  double value = 0;
  bool percent = false;
  double Resolve(double range) const { return percent ? value * range / 100 : value; }
};

// The query's criteria in the input grid's own coordinates and units, as
// the command line takes them.
struct CriteriaSpec {
  Amount error;
  // x0,y0,z0,x1,y1,z1[,t0,t1] (DESIGN.md's contract): 6 numbers, or 8 for
  // the HP (without t0,t1 the box spans all of time).
  std::optional<std::vector<double>> box;
  std::optional<double> iso;
  std::optional<double> time;
};

// Checks the spec against a store of dimension D over a domain of side
// 2^domain_bits with field range `range`, and converts it to lattice units.
// Box bounds round outward to the lattice (exact for bounds that are
// multiples of 2^-(kCoordBits - k) grid steps, integers included). Errors:
// InvalidArgument naming the value and what was expected.
template <int D>
Result<Criteria<D>> MakeCriteria(const CriteriaSpec& spec, int domain_bits, double range);

}  // namespace simplexdb
