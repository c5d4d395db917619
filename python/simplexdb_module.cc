// _simplexdb: the C++ half of the Python package `simplexdb` (python/simplexdb
// holds the Python half, which is the API users see). Each function turns
// Python arguments into an operation's request (ops/: the same functions
// and checks `simplexdb` runs) and the result into Python objects.
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
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ops/amount.h"
#include "ops/code_json.h"
#include "ops/convert.h"
#include "ops/export.h"
#include "ops/extract.h"
#include "ops/extract_output.h"
#include "ops/isosurface.h"
#include "query/surface_io.h"
#include "ops/import.h"
#include "ops/read_grid.h"
#include "ops/store_info.h"
#include "ops/verify.h"
#include "query/field_at.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "storage/io/file.h"
#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"

namespace py = pybind11;

namespace simplexdb {
namespace {

// The library's messages name an option as the command line spells it
// (ops/ checks both front ends' requests); Python names its argument.
std::string PythonWords(std::string message) {
  static const std::pair<std::string_view, std::string_view> kNames[] = {
      {"--time-limit", "time_limit"}, {"--time", "time"},       {"--error", "error"},
      {"--box", "box"},               {"--iso", "iso"},         {"--units", "units"},
      {"--algorithm", "algorithm"},   {"--budget", "budget"},   {"--from", "previous"},
      {"--spacing", "spacing"},       {"--origin", "origin"},   {"--hierarchy", "hierarchy"},
      {"--quantization", "quantization"}, {"--compression", "compression"}, {"--tolerance", "tolerance"},
      {"--threads", "threads"},       {"--dims", "dims"},       {"--type", "dtype"},
      {"--offset", "offset"},         {"--sparse", "sparse=True"}, {"--roi", "roi"},
      {"--step", "step"},             {"--memory-mb", "memory_mb"}, {"--to", "to"},
      {"--force", "force=True"},      {"--slices", "slices"},   {"--zstd-level", "zstd_level"},
  };
  const auto word = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_'; };
  std::string out;
  for (size_t i = 0; i < message.size();) {
    bool replaced = false;
    if (message.compare(i, 2, "--") == 0 && (i == 0 || !word(message[i - 1]))) {
      for (const auto& [cli, py] : kNames) {
        const size_t end = i + cli.size();
        if (message.compare(i, cli.size(), cli) == 0 && (end == message.size() || !word(message[end]))) {
          out += py;
          i = end;
          replaced = true;
          break;
        }
      }
    }
    if (!replaced) out += message[i++];
  }
  return out;
}

[[noreturn]] void Raise(const Status& s) {
  const std::string message = PythonWords(std::string(s.message()));
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

// A JSON object (an operation's report) as the dict Python's json module
// reads from its text, so a script sees what the command prints.
py::dict DictOf(const nlohmann::ordered_json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// The store's description as `simplexdb info --json` prints it (one
// builder, ops/store_info.h).
py::dict InfoDict(const AnyStore& store) { return DictOf(StoreInfoJson(store)); }

// An amount as Python gives it: a number (field units) or text ("1%").
Amount AmountOf(const py::object& value, const char* option) {
  if (py::isinstance<py::str>(value)) {
    Result<Amount> a = ParseAmount(value.cast<std::string>(), option);
    if (!a.ok()) Raise(a.status());
    return *a;
  }
  return Amount{value.cast<double>(), false};
}

// Progress as the command draws it, on Python's sys.stderr (so that
// contextlib.redirect_stderr takes it) and only when that is a terminal
// (a notebook or a redirected stderr gets no escape codes, as a script
// running the command gets none); clears the line when it goes out of
// scope. Constructed with the GIL held; the callback takes it to write.
class ProgressPrinter {
 public:
  ProgressPrinter(bool enabled, std::string output) : output_(std::move(output)) {
    if (!enabled) return;
    py::object err = py::module_::import("sys").attr("stderr");
    if (err.is_none() || !py::hasattr(err, "isatty") || !err.attr("isatty")().cast<bool>()) return;
    stderr_ = std::move(err);
  }
  ~ProgressPrinter() {
    if (drawn_) Write("\r\033[K");
  }
  std::function<void(const BuildProgress&)> callback() {
    if (!stderr_) return {};
    return [this](const BuildProgress& p) {
      Write("\r\033[K" + DescribeProgress(output_, p));
      drawn_ = true;
    };
  }

 private:
  void Write(const std::string& text) {
    py::gil_scoped_acquire held;
    try {
      stderr_.attr("write")(text);
      stderr_.attr("flush")();
    } catch (const py::error_already_set&) {
      // A stream that refuses to write is no reason to stop a build.
    }
  }
  std::string output_;
  py::object stderr_;  // null: no progress
  bool drawn_ = false;
};

// The output path checked as the command checks it (ResolveOutput).
std::string Output(const std::string& path, const std::vector<std::string>& inputs, bool force = false) {
  Result<std::string> resolved = ResolveOutput(path, {.force = force, .inputs = inputs});
  if (!resolved.ok()) Raise(resolved.status());
  return *std::move(resolved);
}

// The criteria both extract and isosurface take, as the command's options.
ExtractRequest CriteriaRequest(const py::object& error, std::optional<std::vector<double>> box,
                               std::optional<double> iso, std::optional<double> time, const std::string& units) {
  ExtractRequest request;
  request.error = AmountOf(error, "--error");
  request.box = std::move(box);
  request.iso = iso;
  request.time = time;
  request.units = units;
  return request;
}

// Extract (ops/extract.h) over the store: the leaves' codes, the
// tetrahedra (the HT's, or the HP's slice at `time`) as arrays, the
// statistics as `extract --format json` prints them.
py::dict ExtractMesh(const std::shared_ptr<AnyStore>& store, const py::object& error,
                     std::optional<std::vector<double>> box, std::optional<double> iso,
                     std::optional<double> time, const std::string& units, const std::string& algorithm,
                     uint64_t budget, std::optional<std::vector<uint64_t>> previous, bool mesh_wanted, int piece,
                     int pieces) {
  ExtractRequest request = CriteriaRequest(error, std::move(box), iso, time, units);
  request.algorithm = algorithm;
  request.budget = budget;
  request.from = std::move(previous);
  request.leaves = true;
  request.tetrahedra = mesh_wanted;
  request.count_slice = mesh_wanted;
  request.piece = piece;
  request.pieces = pieces;
  Result<ExtractResult> result = [&] {
    py::gil_scoped_release unlocked;
    return Extract(*store, request);
  }();
  if (!result.ok()) Raise(result.status());
  ExtractResult& out = *result;
  py::dict d;
  const auto n_codes = static_cast<py::ssize_t>(out.leaves.size());
  d["stats"] = DictOf(ExtractStatsJson(out));
  d["codes"] = Hand(std::move(out.leaves), {n_codes});
  if (out.mesh) {
    TetMeshData& m = *out.mesh;
    const auto points = static_cast<py::ssize_t>(m.field.size()), cells = static_cast<py::ssize_t>(m.cells());
    d["points"] = Hand(std::move(m.points), {points, 3});
    d["cells"] = Hand(std::move(m.connectivity), {cells, 4});
    d["field"] = Hand(std::move(m.field), {points});
    d["error"] = Hand(std::move(m.error), {cells});
    d["level"] = Hand(std::move(m.level), {cells});
    d["cell_codes"] = Hand(std::move(m.code), {cells});
  }
  if (out.mesh_time) d["time"] = *out.mesh_time;
  return d;
}

// The isosurface (ops/isosurface.h, query/isosurface.h) at `iso` of the
// leaves Extract gives for the same criteria, as arrays, and the
// statistics as `isosurface --json` prints them.
py::dict Isosurface(const std::shared_ptr<AnyStore>& store, double iso, const py::object& error,
                    std::optional<std::vector<double>> box, std::optional<double> time, const std::string& units) {
  ExtractRequest request = CriteriaRequest(error, std::move(box), iso, time, units);
  request.leaves = false;
  request.surface = true;
  Result<ExtractResult> result = [&] {
    py::gil_scoped_release unlocked;
    return Extract(*store, request);
  }();
  if (!result.ok()) Raise(result.status());
  SurfaceData& s = *result->surface;
  const auto points = static_cast<py::ssize_t>(s.point_count()), triangles = static_cast<py::ssize_t>(s.triangle_count());
  py::dict d;
  d["stats"] = DictOf(ExtractStatsJson(*result));
  d["points"] = Hand(std::move(s.points), {points, 3});
  d["normals"] = Hand(std::move(s.normals), {points, 3});
  d["triangles"] = Hand(std::move(s.triangles), {triangles, 3});
  d["error"] = Hand(std::move(s.error), {triangles});
  d["comment"] = SurfaceComment(iso, result->info.path);
  return d;
}

// A surface's arrays to .vtp or .ply, by the writers `simplexdb
// isosurface` uses (query/surface_io.h).
void SaveSurface(const std::string& path, py::array_t<double, py::array::c_style | py::array::forcecast> points,
                 py::array_t<float, py::array::c_style | py::array::forcecast> normals,
                 py::array_t<int64_t, py::array::c_style | py::array::forcecast> triangles,
                 py::array_t<double, py::array::c_style | py::array::forcecast> error, const std::string& comment) {
  const Result<std::string> format = SurfaceFormatOf(path);
  if (!format.ok()) throw py::value_error(std::string(format.status().message()));
  SurfaceData s;
  s.points.assign(points.data(), points.data() + points.size());
  s.normals.assign(normals.data(), normals.data() + normals.size());
  s.triangles.assign(triangles.data(), triangles.data() + triangles.size());
  s.error.assign(error.data(), error.data() + error.size());
  if (s.points.size() % 3 != 0 || s.normals.size() != s.points.size() || s.triangles.size() % 3 != 0 ||
      s.error.size() != s.triangle_count()) {
    throw py::value_error(path + ": the surface's arrays do not agree in length");
  }
  for (const int64_t p : s.triangles) {
    if (p < 0 || static_cast<uint64_t>(p) >= s.point_count()) {
      throw py::value_error(path + ": a triangle names point " + std::to_string(p) + ", outside 0.." +
                            std::to_string(s.point_count()));
    }
  }
  Status status;
  {
    py::gil_scoped_release unlocked;
    status = *format == "vtp" ? WriteVtp(s, path) : WritePly(s, path, comment);
  }
  if (!status.ok()) Raise(status);
}

// A mesh's arrays to .vtu or .pvd, by the writer `simplexdb extract` uses
// (WriteMeshFile, ops/extract_output.h).
void SaveMesh(const std::string& path, py::array_t<double, py::array::c_style | py::array::forcecast> points,
              py::array_t<int64_t, py::array::c_style | py::array::forcecast> cells,
              py::array_t<double, py::array::c_style | py::array::forcecast> field,
              py::array_t<double, py::array::c_style | py::array::forcecast> error,
              py::array_t<uint8_t, py::array::c_style | py::array::forcecast> level,
              py::array_t<uint64_t, py::array::c_style | py::array::forcecast> codes, double time) {
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
    s = WriteMeshFile(m, path, time);
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
// (raw when dims are given, else NRRD/NIfTI by its extension); the build
// is ImportVolume's (ops/import.h), the options checked by CheckImport.
void ImportVolumeCore(const py::object& input, const std::string& output,
                      const std::string& hierarchy, const std::string& quantization,
                      const std::string& compression, std::optional<std::vector<double>> spacing,
                      std::optional<std::vector<double>> origin, bool sparse, const py::object& tolerance,
                      bool progress, std::optional<std::string> source,
                      std::optional<std::vector<uint32_t>> dims, const std::string& type,
                      const std::string& endian, uint64_t offset, int threads) {
  ImportOptions options;
  options.threads = threads;
  options.hierarchy = hierarchy;
  options.sparse = sparse;
  options.tolerance = AmountOf(tolerance, "--tolerance");
  options.spacing = std::move(spacing);
  options.origin = std::move(origin);
  Result<Quantization> q = ParseQuantization(quantization);
  if (!q.ok()) throw py::value_error("--quantization: " + std::string(q.status().message()));
  options.quantization = *q;
  Result<Compression> c = ParseCompression(compression);
  if (!c.ok()) throw py::value_error("--compression: " + std::string(c.status().message()));
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
  if (const Status s = CheckImport(*volume, options); !s.ok()) Raise(s);
  const std::string resolved = Output(output, volume->files);
  ProgressPrinter printer(progress, output);
  options.progress = printer.callback();
  const Result<ImportReport> report = [&] {
    py::gil_scoped_release unlocked;  // `input` stays referenced by the caller's frame
    return ImportVolume(*volume, resolved, options);
  }();
  if (!report.ok()) Raise(report.status());
}

// ExportRequest from Python's arguments (roi and step checked for type in
// __init__.py; their values by ResolveExportBox).
ExportRequest ExportRequestOf(std::optional<std::vector<double>> roi, int64_t step, std::optional<double> time) {
  ExportRequest request;
  request.roi = std::move(roi);
  request.step = step;
  request.time = time;
  return request;
}

// The field as ReadExport (ops/export.h) reads it, a C-order array of shape
// (Z, Y, X), or (T, Z, Y, X) for an HP without `time`.
py::array_t<double> ExportField(const std::shared_ptr<AnyStore>& store, std::optional<std::vector<double>> roi,
                                int64_t step, std::optional<double> time) {
  const ExportRequest request = ExportRequestOf(std::move(roi), step, time);
  Result<FieldImage> image = [&] {
    py::gil_scoped_release unlocked;
    return ReadExport(*store, request);
  }();
  if (!image.ok()) Raise(image.status());
  std::vector<py::ssize_t> shape;
  for (int c = image->dimension - 1; c >= 0; --c) shape.push_back(image->dims[c]);
  return Hand(std::move(image->values), shape);
}

// The files `simplexdb export STORE -o OUT` writes (ExportToFiles); returns
// what was written, as the command says it.
std::string ExportFile(const std::shared_ptr<AnyStore>& store, const std::string& out,
                       std::optional<std::vector<double>> roi, int64_t step, std::optional<double> time,
                       bool force) {
  const ExportRequest request = ExportRequestOf(std::move(roi), step, time);
  const std::string resolved = Output(out, {store->path()}, force);
  OutputOptions options;
  options.force = force;
  Result<ExportReport> report = [&] {
    py::gil_scoped_release unlocked;
    return ExportToFiles(*store, request, resolved, options);
  }();
  if (!report.ok()) Raise(report.status());
  return report->written;
}

// `simplexdb convert INPUT -o OUTPUT --to TO ...` (Convert, ops/convert.h).
void ConvertStore(const std::string& input, const std::string& output, const std::string& to,
                  const py::object& tolerance, const std::string& compression, double memory_mb, int threads,
                  bool progress) {
  ConvertOptions options;
  Result<StoreKind> kind = ParseStoreKind(to);
  if (!kind.ok()) Raise(kind.status());
  options.to = *kind;
  options.tolerance = AmountOf(tolerance, "--tolerance");
  Result<Compression> c = ParseCompression(compression);
  if (!c.ok()) throw py::value_error("--compression: " + std::string(c.status().message()));
  options.compression = *c;
  if (!(memory_mb >= 0) || memory_mb > 1e15) throw py::value_error("memory_mb: expected a size in MiB >= 0");
  options.memory_bytes = static_cast<size_t>(memory_mb * 1024 * 1024);
  options.threads = threads;
  if (const Status s = CheckConvert(input, ProbeStoreKind(input), options); !s.ok()) Raise(s);
  const std::string resolved = Output(output, {input});
  ProgressPrinter printer(progress, output);
  options.progress = printer.callback();
  const Result<ConvertReport> report = [&] {
    py::gil_scoped_release unlocked;
    return Convert(input, resolved, options);
  }();
  if (!report.ok()) Raise(report.status());
}

// VerifyStore (ops/verify.h): what was checked, as a dict.
py::dict Verify(const std::shared_ptr<AnyStore>& store) {
  Result<VerifyReport> r = [&] {
    py::gil_scoped_release unlocked;
    return VerifyStore(*store);
  }();
  if (!r.ok()) Raise(r.status());
  py::dict d;
  d["kind"] = StoreKindName(r->kind);
  d["blocks"] = r->blocks;
  if (r->kind == StoreKind::kDense) {
    d["bricks"] = r->bricks;
  } else {
    d["kept"] = r->kept;
  }
  return d;
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
        // Whatever keeps a file from opening as a store (missing, not a
        // store, damaged, of another format) is the file's: OSError.
        if (!store.ok()) {
          PyErr_SetString(PyExc_OSError, std::string(store.status().message()).c_str());
          throw py::error_already_set();
        }
        return std::make_shared<AnyStore>(std::move(store).value());
      },
      py::arg("path"), py::arg("cache_mb"), py::arg("in_memory"));
  m.def("extract", &ExtractMesh, py::arg("store"), py::arg("error"), py::arg("box"), py::arg("iso"),
        py::arg("time"), py::arg("units"), py::arg("algorithm"), py::arg("budget"), py::arg("previous"),
        py::arg("mesh"), py::arg("piece"), py::arg("pieces"));
  m.def("isosurface", &Isosurface, py::arg("store"), py::arg("iso"), py::arg("error"), py::arg("box"),
        py::arg("time"), py::arg("units"));
  m.def("save_surface", &SaveSurface, py::arg("path"), py::arg("points"), py::arg("normals"),
        py::arg("triangles"), py::arg("error"), py::arg("comment"));
  m.def("save_mesh", &SaveMesh, py::arg("path"), py::arg("points"), py::arg("cells"), py::arg("field"),
        py::arg("error"), py::arg("level"), py::arg("codes"), py::arg("time"));
  m.def("code_string", [](int dimension, uint64_t key) {
    if (dimension == 3) return CodeString<3>(key);
    if (dimension == 4) return CodeString<4>(key);
    throw py::value_error("dimension: expected 3 or 4");
  });
  m.def("import_volume", &ImportVolumeCore, py::arg("input"), py::arg("output"), py::arg("hierarchy"),
        py::arg("quantization"), py::arg("compression"), py::arg("spacing"), py::arg("origin"),
        py::arg("sparse"), py::arg("tolerance"), py::arg("progress"), py::arg("source"), py::arg("dims"),
        py::arg("type"), py::arg("endian"), py::arg("offset"), py::arg("threads"));
  m.def("export", &ExportField, py::arg("store"), py::arg("roi"), py::arg("step"), py::arg("time"));
  m.def("export_file", &ExportFile, py::arg("store"), py::arg("out"), py::arg("roi"), py::arg("step"),
        py::arg("time"), py::arg("force"));
  m.def("convert", &ConvertStore, py::arg("input"), py::arg("output"), py::arg("to"), py::arg("tolerance"),
        py::arg("compression"), py::arg("memory_mb"), py::arg("threads"), py::arg("progress"));
  m.def("verify", &Verify, py::arg("store"));
  m.def("field_at", &FieldAtPoints, py::arg("store"), py::arg("points"));
  m.def("describe_code", [](const std::string& hierarchy, const std::string& text) {
    Result<std::string> line = DescribeCode(hierarchy, text);
    if (!line.ok()) Raise(line.status());
    return *line;
  });
  m.def("voxel_type", [](const std::shared_ptr<AnyStore>& store) {
    return std::string(VoxelTypeName(StoreVoxelType(*store)));
  });
}
