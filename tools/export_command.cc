// `simplexdb export`: a store's field (either kind) back out as an image,
// through ExportToFiles (ops/export.h), which the Python package's
// Store.export(out=...) calls too. Here: the options parsed, one line
// printed.
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "ops/export.h"
#include "query/open_store.h"
#include "storage/volume/volume.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

struct ExportArgs {
  std::string store;
  std::string output;
  std::string roi;
  std::string time;  // empty: not given
  int64_t step = 1;
  bool force = false;
};

void RunExport(ExportArgs a) {
  a.output = CheckOutput(a.output, {a.store}, a.force);
  ExportRequest request;
  if (!a.roi.empty()) request.roi = ParseNumberList(a.roi, "--roi", 1, 8);
  if (!a.time.empty()) request.time = ParseNumberList(a.time, "--time", 1, 1)[0];
  request.step = a.step;
  Result<AnyStore> store = AnyStore::Open(a.store);
  if (!store.ok()) Fail(store.status());
  CheckUsage(ResolveExportBox(store->info(), request).status());
  CheckUsage(CheckExportOutput(store->info(), request, a.output));
  OutputOptions options;
  options.force = a.force;
  const Result<ExportReport> r = ExportToFiles(*store, request, a.output, options);
  if (!r.ok()) Fail(r.status());
  if (r->time_steps > 0) {
    fmt::print("{}: {} {} values ({} in {} time steps) written to {}\n", a.store, r->values,
               VoxelTypeName(r->type), FormatDims(3, r->dims), r->time_steps, r->written);
    return;
  }
  fmt::print("{}: {} {} values ({}{}) written to {}\n", a.store, r->values, VoxelTypeName(r->type),
             FormatDims(r->dimension, r->dims),
             r->time_step ? fmt::format(", time step {}", *r->time_step) : "", r->written);
}

// `simplexdb export --help`.
constexpr const char* kExportHelp = R"(Write a store's field back out: OUT.nrrd as one NRRD file, anything else
as raw with a detached NRRD header beside it (OUT.raw + OUT.nhdr). Values
are the store's own, losslessly; a sparse store's rebuilt ones (exact when
lossless; at a tolerance an integer field's are rounded to its type). A 3D
image says where it is: "space directions" and "space origin" from the
store's spacing and origin.
A 4D (HP) store is written as one 3D image per time step (VTK's NRRD
reader, and so ParaView, reads no 4D NRRD as 4D: it takes the first axis
for vector components):
  -o OUT.pvd   OUT_t0000.vti, OUT_t0001.vti, ... (VTK XML image data) and
               OUT.pvd listing them with their times (origin_t + t *
               spacing_t): ParaView opens OUT.pvd as a time series.
  -o OUT.nrrd  OUT_t0000.nrrd, ... (for VTK, Slicer, ITK) and OUT.pvd
               listing them (for scripts: ParaView's .pvd reader opens
               VTK XML files only).
  --time T     the one 3D time step T as OUT.nrrd (or OUT.raw).
Files are named by the grid time t. To OUT.raw a 4D store stays one 4D
file (x fastest, t slowest) for teem, ITK and Slicer. VTK also takes an
x axis of 9 points or fewer for vector components, whatever the header.
Every file is complete before the first is renamed into place: a failure
while writing leaves none of them.
Example: simplexdb export tooth.sdb --roi 0,0,0,50,50,80 --step 2 -o part.nrrd
         simplexdb export flow.sdb -o flow.pvd
         simplexdb export flow.sdb --time 3 -o flow_t3.nrrd)";

}  // namespace

void RegisterExportCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<ExportArgs>(app, "export", kExportHelp, RunExport);
  cmd->add_option("store", a->store, "a store file (dense or sparse)")->required();
  AddOutputOptions(cmd, &a->output, &a->force,
                   "OUT.nrrd (a 4D store: OUT_t<t>.nrrd per step + OUT.pvd), OUT.pvd (a 4D "
                   "store: OUT_t<t>.vti per step), or OUT.raw (+ OUT.nhdr)");
  cmd->add_option("--roi", a->roi,
                  "x0,y0,z0[,t0],x1,y1,z1[,t1]: a box of the grid, inclusive, one range per "
                  "axis of the store; with --time the three space axes only");
  cmd->add_option("--time", a->time, "a 4D store: only time step T (grid units, 0..T-1) as a 3D image");
  cmd->add_option("--step", a->step,
                  "every step-th point along each axis (a coarser resolution); in a 4D "
                  "export without --time, every step-th time step too")
      ->capture_default_str();
}

}  // namespace simplexdb::tools
