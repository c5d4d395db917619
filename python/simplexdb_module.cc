// _simplexdb: the C++ half of the Python package `simplexdb` (python/simplexdb
// holds the Python half, which is the API users see).
//
// What crosses the boundary: a Store (an AnyStore, shared by reference
// count so meshes and threads may outlive the Python name), and the result
// of a query as numpy arrays that own their C++ buffers (the vectors are
// moved into a capsule, not copied). Errors: a Status becomes ValueError
// (InvalidArgument, NotSupported), OSError (NotFound, IOError, Corruption,
// ResourceExhausted) or RuntimeError, with the Status's message.
//
// The GIL is released while a store opens and while a query runs, so
// several Python threads can query one store at once (AnyStore::Visit is
// const and makes a source per call).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "query/clip.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "query/pvd_writer.h"
#include "query/refine.h"
#include "query/slice.h"
#include "query/store_info.h"

namespace py = pybind11;

namespace simplexdb {
namespace {

[[noreturn]] void Raise(const Status& s) {
  const std::string message(s.message());
  if (s.IsInvalidArgument() || s.IsNotSupported()) throw py::value_error(message);
  if (s.IsNotFound() || s.IsIOError() || s.IsCorruption() || s.IsResourceExhausted()) {
    PyErr_SetString(PyExc_OSError, message.c_str());
    throw py::error_already_set();
  }
  throw std::runtime_error(message);
}

// A numpy array over `v`'s buffer, which it then owns.
template <class T>
py::array_t<T> Hand(std::vector<T>&& v, std::vector<py::ssize_t> shape) {
  auto* owned = new std::vector<T>(std::move(v));
  py::capsule free(owned, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, owned->data(), free);
}

// The store's description as `simplexdb info --json` prints it (one
// builder, query/store_info.h), through Python's json so the dict holds
// exactly what a script reading the command's output gets.
py::dict InfoDict(const AnyStore& store) {
  const std::string text = StoreInfoJson(store).dump();
  return py::module_::import("json").attr("loads")(text);
}

// What a query hands back before it becomes numpy arrays.
struct Extraction {
  std::vector<uint64_t> codes;
  TetMeshData mesh;  // the HT's tetrahedra, or the HP's time slice; empty otherwise
  QueryStats stats;
  bool has_mesh = false;
};

py::dict Extract(const std::shared_ptr<AnyStore>& store, double error, std::optional<std::vector<double>> box,
                 std::optional<double> iso, std::optional<double> time, const std::string& algorithm_name,
                 uint64_t budget, bool mesh_wanted) {
  Result<Algorithm> algorithm = ParseAlgorithm(algorithm_name);
  if (!algorithm.ok()) Raise(algorithm.status());
  if (*algorithm == Algorithm::kIncremental) {
    throw py::value_error("algorithm incremental refines a previous mesh; not offered here yet");
  }
  CriteriaSpec spec;
  spec.error.value = error;
  spec.box = std::move(box);
  spec.iso = iso;
  spec.time = time;
  Extraction out;
  Status s;
  {
    py::gil_scoped_release unlocked;
    s = store->Visit([&]<int D, class Source>(Source& source) -> Status {
      const SourceInfo& info = source.info();
      SDB_ASSIGN_OR_RETURN(const Criteria<D> criteria, MakeCriteria<D>(spec, info.domain_bits, info.field_range()));
      RefineOptions options;
      options.algorithm = *algorithm;
      options.max_simplices = budget;
      Refiner<D, Source> refiner(source, criteria);
      Mesh<D> mesh;
      SDB_RETURN_IF_ERROR(refiner.Run(options, mesh, out.stats));
      for (const SimplexCode<D> c : mesh.Leaves()) out.codes.push_back(c.key());
      if (!mesh_wanted) return Status::OK();
      if constexpr (D == 3) {
        SDB_ASSIGN_OR_RETURN(out.mesh, CollectTetMesh(mesh, source));
        out.has_mesh = true;
      } else if (criteria.time) {
        SDB_ASSIGN_OR_RETURN(out.mesh, SliceHpMesh(mesh, source, *criteria.time));
        out.has_mesh = true;
      }
      if (out.has_mesh) {
        out.mesh = ClipToGrid(std::move(out.mesh), info.dims);
        PlacePhysically(out.mesh, info);
      }
      return Status::OK();
    });
  }
  if (!s.ok()) Raise(s);
  py::dict d;
  const auto n_codes = static_cast<py::ssize_t>(out.codes.size());
  d["codes"] = Hand(std::move(out.codes), {n_codes});
  if (out.has_mesh) {
    TetMeshData& m = out.mesh;
    const auto points = static_cast<py::ssize_t>(m.field.size()), cells = static_cast<py::ssize_t>(m.cells());
    d["points"] = Hand(std::move(m.points), {points, 3});
    d["cells"] = Hand(std::move(m.connectivity), {cells, 4});
    d["field"] = Hand(std::move(m.field), {points});
    d["error"] = Hand(std::move(m.error), {cells});
    d["level"] = Hand(std::move(m.level), {cells});
    d["cell_codes"] = Hand(std::move(m.code), {cells});
  }
  const QueryStats& st = out.stats;
  py::dict stats;
  stats["algorithm"] = AlgorithmName(*algorithm);
  stats["simplices"] = st.simplices;
  stats["splits"] = st.splits;
  stats["cluster_computations"] = st.cluster_computations;
  stats["candidates"] = st.candidates;
  stats["error_lookups"] = st.error_lookups;
  stats["field_lookups"] = st.field_lookups;
  stats["blocks_read"] = st.blocks_read;
  stats["blocks_skipped"] = st.blocks_skipped;
  stats["seconds"] = st.seconds;
  stats["interrupted"] = st.interrupted;
  d["stats"] = stats;
  return d;
}

// The file VTK reads, by the writer `simplexdb extract` uses.
void SaveVtu(const std::string& path, py::array_t<double, py::array::c_style | py::array::forcecast> points,
             py::array_t<int64_t, py::array::c_style | py::array::forcecast> cells,
             py::array_t<double, py::array::c_style | py::array::forcecast> field,
             py::array_t<double, py::array::c_style | py::array::forcecast> error,
             py::array_t<uint8_t, py::array::c_style | py::array::forcecast> level,
             py::array_t<uint64_t, py::array::c_style | py::array::forcecast> codes) {
  TetMeshData m;
  m.points.assign(points.data(), points.data() + points.size());
  m.connectivity.assign(cells.data(), cells.data() + cells.size());
  m.field.assign(field.data(), field.data() + field.size());
  m.error.assign(error.data(), error.data() + error.size());
  m.level.assign(level.data(), level.data() + level.size());
  m.code.assign(codes.data(), codes.data() + codes.size());
  if (m.points.size() != 3 * m.field.size() || m.connectivity.size() % 4 != 0 || m.error.size() != m.cells() ||
      m.level.size() != m.cells() || m.code.size() != m.cells()) {
    throw py::value_error(path + ": the mesh's arrays do not agree in length");
  }
  for (const int64_t p : m.connectivity) {
    if (p < 0 || static_cast<uint64_t>(p) >= m.field.size()) {
      throw py::value_error(path + ": a cell names point " + std::to_string(p) + ", outside 0.." +
                            std::to_string(m.field.size()));
    }
  }
  Status s;
  {
    py::gil_scoped_release unlocked;
    s = WriteVtu(m, path);
  }
  if (!s.ok()) Raise(s);
}

// A ParaView collection naming (time, file) pairs, by the writer `simplexdb
// extract -o X.pvd` uses.
void SavePvd(const std::string& path, const std::vector<std::pair<double, std::string>>& datasets) {
  std::vector<PvdDataSet> sets;
  for (const auto& [time, file] : datasets) {
    if (file.find('/') != std::string::npos) {
      throw py::value_error(path + ": a .pvd names files beside it, not " + file);
    }
    sets.push_back({time, file});
  }
  Status s;
  {
    py::gil_scoped_release unlocked;
    s = WritePvd(sets, path);
  }
  if (!s.ok()) Raise(s);
}

template <int D>
std::string CodeString(uint64_t key) {
  return SimplexCode<D>::FromKey(key).ToString();
}

}  // namespace
}  // namespace simplexdb

PYBIND11_MODULE(_simplexdb, m) {
  using namespace simplexdb;
  m.doc() = "SimplexDB's C++ core; use the `simplexdb` package";
  py::class_<AnyStore, std::shared_ptr<AnyStore>>(m, "Store")
      .def_property_readonly("info", &InfoDict)
      .def_property_readonly("dimension", &AnyStore::dimension)
      .def_property_readonly("path", &AnyStore::path);
  m.def(
      "open",
      [](const std::string& path, double cache_mb, bool in_memory) {
        if (!(cache_mb >= 0)) throw py::value_error("cache_mb: expected a size in MiB >= 0");
        StoreOptions options;
        options.cache_bytes = static_cast<size_t>(cache_mb * 1024 * 1024);
        options.in_memory = in_memory;
        Result<AnyStore> store = [&] {
          py::gil_scoped_release unlocked;
          return AnyStore::Open(path, options);
        }();
        if (!store.ok()) Raise(store.status());
        return std::make_shared<AnyStore>(std::move(store).value());
      },
      py::arg("path"), py::arg("cache_mb"), py::arg("in_memory"));
  m.def("extract", &Extract, py::arg("store"), py::arg("error"), py::arg("box"), py::arg("iso"), py::arg("time"),
        py::arg("algorithm"), py::arg("budget"), py::arg("mesh"));
  m.def("save_vtu", &SaveVtu);
  m.def("save_pvd", &SavePvd);
  m.def("code_string", [](int dimension, uint64_t key) {
    if (dimension == 3) return CodeString<3>(key);
    if (dimension == 4) return CodeString<4>(key);
    throw py::value_error("dimension: expected 3 or 4");
  });
}
