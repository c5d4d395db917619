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

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "query/clip.h"
#include "query/code_json.h"
#include "query/criteria.h"
#include "query/field_at.h"
#include "query/import_volume.h"
#include "query/mesh.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "query/pvd_writer.h"
#include "query/read_grid.h"
#include "query/refine.h"
#include "query/slice.h"
#include "query/store_info.h"
#include "storage/io/file.h"
#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"

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

// --- import_volume, export, field_at (simplexdb/__init__.py checks the
// arguments' shapes and types first; these check what only C++ knows) ---

// The voxels of a numpy array, read in place (MemoryVolume): `dims` x
// fastest, as __init__.py derived them from the array's memory order.
// REQUIRES: the caller holds `array` until every reader is gone (the build
// runs inside ImportVolume below, which holds it).
Result<VolumeInfo> ArrayVolume(const py::array& array, const std::vector<uint32_t>& dims,
                               const std::string& type_name, const std::string& endian,
                               const std::string& description) {
  SDB_ASSIGN_OR_RETURN(const VoxelType type, ParseVoxelType(type_name));
  std::array<uint32_t, 4> d = {1, 1, 1, 1};
  if (dims.size() < 3 || dims.size() > 4) return Status::InvalidArgument("array: expected 3 or 4 axes");
  uint64_t count = 1;
  for (size_t i = 0; i < dims.size(); ++i) {
    d[i] = dims[i];
    count *= dims[i];
  }
  const bool contiguous = (array.flags() & (py::array::c_style | py::array::f_style)) != 0;
  if (!contiguous || static_cast<uint64_t>(array.nbytes()) != count * VoxelSize(type)) {
    return Status::InvalidArgument("array: expected " + std::to_string(count) + " contiguous " +
                                   std::string(VoxelTypeName(type)) + " voxels, got " +
                                   std::to_string(array.nbytes()) + " bytes");
  }
  // Not owned: the array outlives the build (REQUIRES above).
  std::shared_ptr<const std::byte> bytes(static_cast<const std::byte*>(array.data()),
                                         [](const std::byte*) {});
  return MemoryVolume(static_cast<int>(dims.size()), d, type,
                      endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle, std::move(bytes),
                      description);
}

// `input` is a numpy array (dims, type and endian describe it) or a path
// (raw when dims are given, else NRRD/NIfTI by its extension).
void ImportVolumeCore(const py::object& input, const std::string& output,
                      const std::string& hierarchy, const std::string& quantization,
                      const std::string& compression, std::optional<std::vector<double>> spacing,
                      std::optional<std::vector<double>> origin, bool sparse, bool progress,
                      std::optional<std::string> source, std::optional<std::vector<uint32_t>> dims,
                      const std::string& type, const std::string& endian, uint64_t offset,
                      int threads) {
  if (threads < 0) {
    throw py::value_error("threads: expected a count >= 0 (0: one per core), not " + std::to_string(threads));
  }
  ImportOptions options;
  options.threads = threads;
  options.hierarchy = hierarchy;
  options.sparse = sparse;
  Result<Quantization> q = ParseQuantization(quantization);
  if (!q.ok()) throw py::value_error("quantization: " + std::string(q.status().message()));
  options.quantization = *q;
  Result<Compression> c = ParseCompression(compression);
  if (!c.ok()) throw py::value_error("compression: " + std::string(c.status().message()));
  options.compression = *c;
  if (dims && dims->size() != 3 && dims->size() != 4) {
    throw py::value_error("dims: expected X, Y, Z[, T], got " + std::to_string(dims->size()) + " numbers");
  }
  const bool is_array = py::isinstance<py::array>(input);
  Result<VolumeInfo> volume = [&]() -> Result<VolumeInfo> {
    if (is_array) {
      std::array<uint32_t, 4> d = {1, 1, 1, 1};
      std::copy(dims->begin(), dims->end(), d.begin());
      return ArrayVolume(input.cast<py::array>(), *dims, type, endian,
                         source ? *source
                                : "numpy array (" + type + ", " +
                                      FormatDims(static_cast<int>(dims->size()), d) + ")");
    }
    if (dims) {
      Result<VoxelType> t = ParseVoxelType(type);
      if (!t.ok()) throw py::value_error("dtype: " + std::string(t.status().message()));
      std::array<uint32_t, 4> d = {1, 1, 1, 1};
      std::copy(dims->begin(), dims->end(), d.begin());
      return OpenRawVolume(input.cast<std::string>(), static_cast<int>(dims->size()), d, *t,
                           endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle, offset);
    }
    return OpenVolume(input.cast<std::string>());
  }();
  if (!volume.ok()) Raise(volume.status());
  if (source && !is_array) volume->description = *source;
  // spacing and origin: one number per axis, x first (as --spacing, --origin).
  for (const auto& [values, name] : {std::pair(&spacing, "spacing"), std::pair(&origin, "origin")}) {
    if (!*values) continue;
    const std::vector<double>& v = **values;
    if (static_cast<int>(v.size()) != volume->dimension) {
      throw py::value_error(std::string(name) + ": " + std::to_string(v.size()) + " numbers for a " +
                            std::to_string(volume->dimension) + "D volume (" +
                            FormatDims(volume->dimension, volume->dims) + "); give " +
                            std::to_string(volume->dimension) + ", x first");
    }
    for (size_t a = 0; a < v.size(); ++a) {
      // As --spacing: x, y, z may be negative (a flipped axis); time's is > 0.
      const bool spacing_axis = std::string(name) == "spacing";
      if (!std::isfinite(v[a]) || (spacing_axis && (a < 3 ? v[a] == 0 : !(v[a] > 0)))) {
        char number[32];
        std::snprintf(number, sizeof number, "%g", v[a]);
        throw py::value_error(std::string(name) + ": " + number + " on axis " +
                              std::to_string(a) + " is not " +
                              (!spacing_axis ? "a finite number"
                               : a < 3       ? "a finite non-zero number (negative: a flipped axis)"
                                             : "a finite number > 0 (time runs forwards)"));
      }
      (spacing_axis ? volume->spacing : volume->origin)[a] = v[a];
    }
  }
  if (const Status s = CheckImport(*volume, options); !s.ok()) Raise(s);
  OutputOptions out_options;
  out_options.inputs = volume->files;
  Result<std::string> resolved = ResolveOutput(output, out_options);
  if (!resolved.ok()) Raise(resolved.status());
  bool drawn = false;
  if (progress) {
    options.progress = [&drawn, output](const BuildProgress& p) {
      std::fprintf(stderr, "\r\033[K%s", DescribeProgress(output, p).c_str());
      std::fflush(stderr);
      drawn = true;
    };
  }
  const Result<ImportReport> report = [&] {
    py::gil_scoped_release unlocked;  // `input` stays referenced by the caller's frame
    return ImportVolume(*volume, *resolved, options);
  }();
  if (drawn) std::fprintf(stderr, "\r\033[K");
  if (!report.ok()) Raise(report.status());
}

// The field on the grid points of `roi` (x0, y0, z0[, t0], x1, y1, z1[, t1],
// inclusive; None: the whole grid), every step-th point, as a C-order
// array of shape (Z, Y, X) or (T, Z, Y, X).
py::array_t<double> ExportField(const std::shared_ptr<AnyStore>& store,
                                std::optional<std::vector<int64_t>> roi, int step) {
  const SourceInfo& info = store->info();
  const int d = info.dimension;
  ExportBox box = WholeGrid(info, step);
  if (roi) {
    if (static_cast<int>(roi->size()) != 2 * d) {
      throw py::value_error("roi: expected " + std::to_string(2 * d) + " grid indices (" +
                            (d == 3 ? "x0, y0, z0, x1, y1, z1" : "x0, y0, z0, t0, x1, y1, z1, t1") +
                            "), got " + std::to_string(roi->size()));
    }
    for (int c = 0; c < d; ++c) {
      box.lo[c] = (*roi)[c];
      box.hi[c] = (*roi)[d + c];
    }
  }
  Result<std::vector<double>> values = [&] {
    py::gil_scoped_release unlocked;
    return ReadGridBox(*store, box);
  }();
  if (!values.ok()) Raise(values.status());
  const std::array<uint32_t, 4> dims = ExportDims(box, d);
  std::vector<py::ssize_t> shape;
  for (int c = d - 1; c >= 0; --c) shape.push_back(dims[c]);
  return Hand(std::move(values).value(), shape);
}

// The field at N points (an N x D array in grid units), FieldAt each.
py::array_t<double> FieldAtPoints(const std::shared_ptr<AnyStore>& store,
                                  py::array_t<double, py::array::c_style | py::array::forcecast> points) {
  const int d = store->dimension();
  if (points.ndim() != 2 || points.shape(1) != d) {
    throw py::value_error("points: expected an N x " + std::to_string(d) + " array, got shape (" +
                          [&] {
                            std::string s;
                            for (py::ssize_t i = 0; i < points.ndim(); ++i) {
                              s += (i ? ", " : "") + std::to_string(points.shape(i));
                            }
                            return s;
                          }() + ")");
  }
  const auto n = static_cast<size_t>(points.shape(0));
  std::vector<double> out(n);
  const double* p = points.data();
  Status s;
  {
    py::gil_scoped_release unlocked;
    s = store->Visit([&]<int D, class Source>(Source& source) -> Status {
      for (size_t i = 0; i < n; ++i) {
        std::array<double, D> x{};
        for (int a = 0; a < D; ++a) x[a] = p[i * D + a];
        SDB_ASSIGN_OR_RETURN(out[i], FieldAt<D>(source, x));
      }
      return Status::OK();
    });
  }
  if (!s.ok()) Raise(s);
  return Hand(std::move(out), {static_cast<py::ssize_t>(n)});
}

std::string StoreVoxelType(const AnyStore& store) {
  return std::string(VoxelTypeName(store.hz() ? store.hz()->header().voxel_type
                                              : store.sparse()->header().voxel_type));
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
  m.def("import_volume", &ImportVolumeCore, py::arg("input"), py::arg("output"), py::arg("hierarchy"),
        py::arg("quantization"), py::arg("compression"), py::arg("spacing"), py::arg("origin"),
        py::arg("sparse"), py::arg("progress"), py::arg("source"), py::arg("dims"), py::arg("type"),
        py::arg("endian"), py::arg("offset"), py::arg("threads"));
  m.def("export", &ExportField, py::arg("store"), py::arg("roi"), py::arg("step"));
  m.def("field_at", &FieldAtPoints, py::arg("store"), py::arg("points"));
  m.def("describe_code", [](const std::string& hierarchy, const std::string& text) {
    Result<std::string> line = DescribeCode(hierarchy, text);
    if (!line.ok()) Raise(line.status());
    return *line;
  });
  m.def("voxel_type", [](const std::shared_ptr<AnyStore>& store) { return StoreVoxelType(*store); });
}
