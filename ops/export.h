// Export: a store's field back out as an image, `simplexdb export` and the
// Python package's Store.export. One function resolves the options to a
// box of the grid and reads it (ReadExport, the values every front end
// gets), one writes the files (ExportToFiles), for stores of either kind: a
// sparse store's values are its rebuilt ones, brought into its voxel type
// (ops/read_grid.h).
//
// Files (ExportToFiles), by the output's name:
//   OUT.nrrd   one NRRD file (a 4D store without --time: OUT_t<t>.nrrd per
//              time step and OUT.pvd listing them)
//   OUT.pvd    a 4D store without --time: OUT_t<t>.vti per time step (VTK
//              XML image data) and OUT.pvd listing them (ParaView opens it)
//   other      raw voxels with a detached NRRD header, OUT(.raw) + OUT.nhdr
// A 3D image says where it is (spacing and origin from the store's); a
// flipped axis (negative spacing) is written forwards, the voxels reversed
// and the origin moved to the last one, as every reader places it. The
// files of a time series are all complete before the first is renamed
// into place (a failure leaves none of them, the .pvd is renamed last).
//
// Thread safety: reentrant over a const store. Lifetimes: values.
//
// Errors: ResolveExportBox and CheckExportOutput return InvalidArgument
// naming the option as the command spells it (--roi, --time, --step, -o);
// then the store's errors (Corruption, IOError) and the writers'
// (storage/io/file.h: the errno of the failing call naming the file,
// ResourceExhausted for a full disk or a series longer than the descriptor
// limit).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ops/read_grid.h"
#include "query/open_store.h"
#include "storage/io/file.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

struct ExportRequest {
  // --roi: x0,y0,z0[,t0],x1,y1,z1[,t1], grid indices, inclusive, one range
  // per axis of the store; with --time the three space axes only.
  std::optional<std::vector<double>> roi;
  std::optional<double> time;  // --time: a 4D store's one time step, as a 3D image
  int64_t step = 1;            // --step: every step-th point along each axis (and time)
};

// The box `request` asks of the grid `info` describes. O(1).
Result<ExportBox> ResolveExportBox(const SourceInfo& info, const ExportRequest& request);

// An image of the field, as read from the store.
struct FieldImage {
  int dimension = 3;  // 3; 4 for a 4D store without --time
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};  // points per axis
  VoxelType type = VoxelType::kU8;
  std::vector<double> values;  // x fastest, every one a value `type` holds
  // Placement: the store's spacing times the step, and the position of the
  // first point (origin + lo x spacing); axes as stored (a flipped axis
  // keeps its negative spacing).
  std::array<double, 4> spacing = {1, 1, 1, 1};
  std::array<double, 4> origin = {0, 0, 0, 0};
  std::optional<int64_t> time_step;  // --time
};

// ResolveExportBox, then the box's values (ReadGridBox). O(points).
Result<FieldImage> ReadExport(const AnyStore& store, const ExportRequest& request);

// What the request may write to `output`: a .pvd only for the time series
// of a 4D store without --time. O(1).
Status CheckExportOutput(const SourceInfo& info, const ExportRequest& request,
                         const std::string& output);

struct ExportReport {
  uint64_t values = 0;  // written, over every file
  VoxelType type = VoxelType::kU8;
  int dimension = 3;  // of one image
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};  // of one image
  std::optional<int64_t> time_step;  // --time
  size_t time_steps = 0;             // a series' images; 0: one image
  std::string written;               // "OUT.nrrd", "OUT.raw and OUT.nhdr", "OUT_t*.vti and OUT.pvd"
};

// Writes the image(s) (the format above). `output` is resolved by the
// caller (ResolveOutput); the other files a series or a raw export writes
// are checked here with `output_options` (the store is added to its
// inputs; a raw export's header never through a symlink).
Result<ExportReport> ExportToFiles(const AnyStore& store, const ExportRequest& request,
                                   const std::string& output, OutputOptions output_options);

}  // namespace simplexdb
