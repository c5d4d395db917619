// The field at the vertices of simplices (query/refine.h's criteria that
// need it, and the meshes' output: query/mesh_io.h), through any source.
//
// Thread safety: one thread's at a time, as its source. Lifetimes: it keeps
// a reference to its source, which outlives it. Errors: the source's, and
// Corruption when a source of a program's own has no value at a vertex.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "query/source.h"
#include "util/status.h"

namespace simplexdb {

// The field at the vertices of simplices, for criteria that need it and for
// output: one Field() lookup per vertex (every store's source has a value
// at every grid point: query/source.h).
template <int D, ReadSource<D> Source>
class VertexValues {
 public:
  using Code = SimplexCode<D>;
  using Values = std::array<double, D + 1>;

  explicit VertexValues(Source& source) : source_(source) {}

  // The value at the midpoint of `code`'s split edge (`v`: its vertices).
  Result<double> Midpoint(Code code, const SimplexVertices<D>& v) {
    return At(code, SplitMidpoint<D>(code, v), -1);
  }

  // The values at the vertices `v` of the root `top`.
  Status RootValues(int top, const SimplexVertices<D>& v, Values& out) {
    return Get(Code::Root(top), v, out);
  }

  // The values at the vertices `v` of `code`.
  Status Get(Code code, const SimplexVertices<D>& v, Values& out) {
    for (int i = 0; i <= D; ++i) {
      SDB_ASSIGN_OR_RETURN(out[i], At(code, v[i], i));
    }
    return Status::OK();
  }

 private:
  // The value at `code`'s vertex `p` (number `vertex`; -1: the midpoint of
  // its split edge). A source of a program's own may have none there.
  Result<double> At(Code code, const Point<D>& p, int vertex) {
    SDB_ASSIGN_OR_RETURN(const std::optional<double> f,
                         source_.Field(LatticeToGrid<D>(p, source_.info().domain_bits)));
    if (f) return *f;
    return Status::Corruption(source_.info().path + ": no field value at " +
                              (vertex < 0 ? "the midpoint of its split edge" : "vertex " + std::to_string(vertex + 1)) +
                              " of simplex " + code.ToString());
  }

  Source& source_;
};

}  // namespace simplexdb
