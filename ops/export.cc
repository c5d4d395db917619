#include "ops/export.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string_view>
#include <utility>

#include <fmt/format.h>

#include "query/pvd_writer.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "storage/volume/vti_writer.h"

namespace simplexdb {
namespace {

bool EndsWith(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The placement of a box: voxel size (the store's spacing times the step)
// and the position of its first point, origin + lo * spacing.
void Place(const SourceInfo& info, const ExportBox& box, FieldImage& image) {
  for (int c = 0; c < info.dimension; ++c) {
    image.spacing[c] = info.spacing[c] * box.step;
    image.origin[c] = info.origin[c] + static_cast<double>(box.lo[c]) * info.spacing[c];
  }
}

// An image of a store with flipped axes (negative spacing), written so that
// every reader places it right: VTK's NRRD reader, and so ParaView, keeps a
// space direction's length and drops its sign. Each flipped axis of the
// image is reversed and its origin moved to its last sample with a positive
// spacing: the same voxels at the same places. O(values).
void FlippedAxesForwards(FieldImage& image) {
  const size_t nx = image.dims[0], ny = image.dims[1];
  std::vector<double>& values = image.values;
  for (size_t c = 0; c < 3; ++c) {
    if (!(image.spacing[c] < 0)) continue;
    image.origin[c] += static_cast<double>(image.dims[c] - 1) * image.spacing[c];
    image.spacing[c] = -image.spacing[c];
    const size_t stride = c == 0 ? 1 : c == 1 ? nx : nx * ny;
    const size_t n = image.dims[c];
    for (size_t start = 0; start < values.size(); ++start) {
      // Each line along axis c starts where its index on c is 0.
      if ((start / stride) % n != 0) continue;
      for (size_t i = 0, j = n - 1; i < j; ++i, --j) {
        std::swap(values[start + i * stride], values[start + j * stride]);
      }
    }
  }
}

// The values of `box` with their placement (axes as stored).
Result<FieldImage> ReadBox(const AnyStore& store, const ExportBox& box) {
  const SourceInfo& info = store.info();
  FieldImage image;
  image.dimension = info.dimension;
  image.dims = ExportDims(box, info.dimension);
  image.type = StoreVoxelType(store);
  SDB_ASSIGN_OR_RETURN(image.values, ReadGridBox(store, box));
  Place(info, box, image);
  return image;
}

std::string_view Folderless(std::string_view path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

// A 4D store without --time, to OUT.nrrd or OUT.pvd: one 3D image per time
// step, OUT_t<t>.nrrd (VTK's NRRD reader, Slicer, ITK) or OUT_t<t>.vti
// (ParaView's .pvd reader opens VTK XML files only), t the grid time (four
// digits or more), and OUT.pvd listing them with their times, origin[3] +
// t * spacing[3]. All files are written to their temporaries first and
// renamed after the last is complete, the .pvd last: a failure while
// writing leaves none of them, and a .pvd never names a missing file (a
// rename failing part-way leaves the steps renamed before it, complete).
// Cost: one open file per step until the renames, so a series longer than
// the descriptor limit (ulimit -n) fails, ResourceExhausted, before any
// file appears; memory for one step's values at a time.
Result<ExportReport> ExportTimeSeries(const AnyStore& store, const ExportBox& box,
                                      const std::string& output, const OutputOptions& options) {
  const SourceInfo& info = store.info();
  const bool vti = EndsWith(output, ".pvd");
  const std::string stem = output.substr(0, output.size() - (vti ? 4 : 5));
  const char* ext = vti ? "vti" : "nrrd";
  const int width = std::max<int>(4, static_cast<int>(std::to_string(info.dims[3] - 1).size()));
  std::vector<std::unique_ptr<AtomicFileWriter>> files;
  std::vector<PvdDataSet> steps;  // time, file name without folder
  ExportReport report;
  report.type = StoreVoxelType(store);
  for (int64_t t = box.lo[3]; t <= box.hi[3]; t += box.step) {
    ExportBox one = box;
    one.lo[3] = one.hi[3] = t;
    SDB_ASSIGN_OR_RETURN(FieldImage image, ReadBox(store, one));
    FlippedAxesForwards(image);
    const std::string name = fmt::format("{}_t{:0{}}.{}", stem, t, width, ext);
    SDB_ASSIGN_OR_RETURN(const std::string path, ResolveOutput(name, options));
    const std::array<uint32_t, 4>& d = image.dims;
    const std::array<double, 4>& s = image.spacing;
    const std::array<double, 3> origin = {image.origin[0], image.origin[1], image.origin[2]};
    Result<std::unique_ptr<AtomicFileWriter>> file =
        vti ? PrepareVti(path, {d[0], d[1], d[2]}, image.type, image.values, {s[0], s[1], s[2]}, origin)
            : PrepareNrrd(path, 3, {d[0], d[1], d[2], 1}, image.type, image.values, s, origin);
    SDB_RETURN_IF_ERROR(file.status());
    files.push_back(*std::move(file));
    steps.push_back({image.origin[3], std::string(Folderless(name))});
    report.values += image.values.size();
    report.dims = {d[0], d[1], d[2], 1};
  }
  for (auto& f : files) SDB_RETURN_IF_ERROR(f->Commit());
  files.clear();
  SDB_ASSIGN_OR_RETURN(const std::string pvd_path, ResolveOutput(stem + ".pvd", options));
  SDB_RETURN_IF_ERROR(WritePvd(steps, pvd_path));
  report.time_steps = steps.size();
  report.written = fmt::format("{}_t*.{} and {}.pvd", stem, ext, stem);
  return report;
}

}  // namespace

Result<ExportBox> ResolveExportBox(const SourceInfo& info, const ExportRequest& request) {
  const int d = info.dimension;
  ExportBox box = WholeGrid(info, 1);
  if (request.step < 1) {
    return Status::InvalidArgument(fmt::format("--step: expected a whole number >= 1, not {}", request.step));
  }
  // A step past an axis's length reads its first point alone; the box's
  // step is an int, and 2^30 is past any axis a store holds.
  box.step = static_cast<int>(std::min<int64_t>(request.step, int64_t{1} << 30));
  int roi_axes = d;
  if (request.time) {
    if (d != 4) {
      return Status::InvalidArgument(fmt::format(
          "--time: {} is a 3D (HT) store; it has no time axis (leave --time out)", info.path));
    }
    const double t = *request.time;
    if (t != std::floor(t) || t < 0 || t > info.dims[3] - 1) {
      return Status::InvalidArgument(
          fmt::format("--time {}: not a time step of {}: expected a whole number in 0..{} (grid units)",
                      t, info.path, info.dims[3] - 1));
    }
    box.lo[3] = box.hi[3] = static_cast<int64_t>(t);
    roi_axes = 3;
  }
  if (request.roi) {
    const std::vector<double>& v = *request.roi;
    const size_t n = 2 * static_cast<size_t>(roi_axes);
    if (d == 4 && roi_axes == 3 && v.size() == 8) {
      return Status::InvalidArgument("--roi with --time is x0,y0,z0,x1,y1,z1: --time gives the time");
    }
    if (v.size() != n) {
      return Status::InvalidArgument(fmt::format(
          "--roi: expected {} grid indices ({}), got {}", n,
          roi_axes == 3 ? "x0,y0,z0,x1,y1,z1" : "x0,y0,z0,t0,x1,y1,z1,t1", v.size()));
    }
    for (int c = 0; c < roi_axes; ++c) {
      const double from = v[static_cast<size_t>(c)], to = v[static_cast<size_t>(roi_axes + c)];
      const double last = static_cast<double>(info.dims[c]) - 1;
      if (from != std::floor(from) || to != std::floor(to) || from < 0 || to > last || from > to) {
        return Status::InvalidArgument(
            fmt::format("--roi: axis {} range {}..{} is not within 0..{}", c, from, to, last));
      }
      box.lo[c] = static_cast<int64_t>(from);
      box.hi[c] = static_cast<int64_t>(to);
    }
  }
  return box;
}

Result<FieldImage> ReadExport(const AnyStore& store, const ExportRequest& request) {
  SDB_ASSIGN_OR_RETURN(const ExportBox box, ResolveExportBox(store.info(), request));
  SDB_ASSIGN_OR_RETURN(FieldImage image, ReadBox(store, box));
  if (request.time) {
    // One time step of an HP is a 3D image.
    image.dimension = 3;
    image.time_step = box.lo[3];
  }
  return image;
}

Status CheckExportOutput(const SourceInfo& info, const ExportRequest& request,
                         const std::string& output) {
  if (EndsWith(output, ".pvd") && (info.dimension != 4 || request.time)) {
    return Status::InvalidArgument(
        fmt::format("-o {}: a .pvd is the time series of a 4D (HP) store without --time; write "
                    "this image as OUT.nrrd",
                    output));
  }
  return Status::OK();
}

Result<ExportReport> ExportToFiles(const AnyStore& store, const ExportRequest& request,
                                   const std::string& output, OutputOptions output_options) {
  const SourceInfo& info = store.info();
  SDB_ASSIGN_OR_RETURN(const ExportBox box, ResolveExportBox(info, request));
  SDB_RETURN_IF_ERROR(CheckExportOutput(info, request, output));
  output_options.inputs.push_back(info.path);
  const bool nrrd = EndsWith(output, ".nrrd");
  if (info.dimension == 4 && !request.time && (nrrd || EndsWith(output, ".pvd"))) {
    return ExportTimeSeries(store, box, output, output_options);
  }
  SDB_ASSIGN_OR_RETURN(FieldImage image, ReadExport(store, request));
  FlippedAxesForwards(image);
  const NrrdOrigin origin = std::array<double, 3>{image.origin[0], image.origin[1], image.origin[2]};
  std::array<double, 4> spacing = image.spacing;
  if (image.dimension == 3) spacing[3] = 1;
  ExportReport report;
  report.values = image.values.size();
  report.type = image.type;
  report.dimension = image.dimension;
  report.dims = image.dims;
  report.time_step = image.time_step;
  report.written = output;
  if (nrrd) {
    SDB_RETURN_IF_ERROR(
        WriteNrrd(output, image.dimension, image.dims, image.type, image.values, spacing, origin));
    return report;
  }
  const std::string base = EndsWith(output, ".raw") ? output.substr(0, output.size() - 4) : output;
  report.written = output + " and " + base + ".nhdr";
  OutputOptions header_options = output_options;  // beside the raw file, never through a link
  header_options.force = false;
  header_options.inputs.push_back(output);
  SDB_ASSIGN_OR_RETURN(const std::string nhdr, ResolveOutput(base + ".nhdr", header_options));
  SDB_RETURN_IF_ERROR(WriteRawWithNhdr(output, nhdr, image.dimension, image.dims, image.type,
                                       image.values, spacing, origin));
  return report;
}

}  // namespace simplexdb
