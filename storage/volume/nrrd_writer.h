// Writing volumes as NRRD, for `simplexdb generate` and `simplexdb export`.
//
// Output is always NRRD0004, encoding raw, little endian, with "spacings:"
// or, for a grid given an origin, "space directions:" and "space origin:"
// for x, y, z (so OpenNrrd, teem, VTK, ITK and 3D Slicer read it). VTK's vtkNrrdReader
// reads no 4D file as 4D (it takes the first axis for vector components, as
// it does an x axis of 9 samples or fewer): write a time series as one 3D
// file per step (PrepareNrrd, for all-or-nothing). Files appear
// atomically, through the one atomic writer (AtomicFileWriter,
// storage/io/file.h): the bytes go to `<path>.tmp.<pid>` in the same
// directory, which is fsynced and renamed over `path`, and the directory is
// fsynced. A crash or error leaves either the old file or the complete new
// one under `path`, never a half-written one; on error the temporary file is
// removed, and one left by a killed process is removed by the next write of
// the same path.
//
// Errors (every message names the file, never a temporary):
//   InvalidArgument    bad dims, values.size() not the voxel count, a value
//                      not representable as `type` (the first one is named
//                      with its voxel index), a non-positive spacing (VTK's
//                      reader drops a direction's sign: write a flipped
//                      axis reversed), an origin not finite.
//   NotFound           the output folder does not exist (or a component of
//                      the path is a regular file).
//   ResourceExhausted  the disk or quota is full.
//   IOError            any other operating-system failure (the errno table
//                      of storage/io/file.h: EACCES, EROFS, EIO, ...).
//
// Thread safety: reentrant; concurrent writes to the same path leave one of
// the complete files.
//
// Lifetimes: nothing is handed back but a Status; the values are only read
// during the call.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "storage/io/file.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// Where a grid sits in space. Without it a file says only "spacings:" (the
// voxel sizes); with it the file says "space dimension: 3", "space
// directions:" (the axes x, y, z scaled by their spacing, no rotation;
// "none" for time) and "space origin:" (the
// position of voxel 0), which VTK's vtkNrrdReader, ParaView, ITK and 3D
// Slicer take as the image's origin; a 4D file's time step stays in
// "spacings: nan nan nan dt".
using NrrdOrigin = std::optional<std::array<double, 3>>;

// Writes `values` (x fastest, then y, z, t) converted to `type` as one NRRD
// file with an attached header.
//
// Every value must be representable as `type` (IsRepresentable: integers in
// range for the integer types; float32 rounds to nearest): the check is a
// cheap pass before anything is written, so a caller's mistake is an
// InvalidArgument rather than undefined behaviour or silent wrapping. Round
// or clamp before calling.
// REQUIRES nothing else: dims are validated (each used axis >= 1, unused
// axes 1, dimension 3 or 4). O(voxels): one pass to check, one to write.
// `origin`: see NrrdOrigin; finite.
Status WriteNrrd(const std::string& path, int dimension,
                 std::array<uint32_t, 4> dims, VoxelType type,
                 std::span<const double> values,
                 std::array<double, 4> spacing = {1, 1, 1, 1},
                 NrrdOrigin origin = std::nullopt);

// WriteNrrd up to, not including, the rename: the complete file is in its
// temporary (`<path>.tmp.<pid>`, flushed by Commit), and nothing is under
// `path` yet. Commit() puts it in place; dropping the writer removes it. For
// a command writing several files that should all appear or none (export's
// time series): prepare every one, then commit them. Same checks and errors
// as WriteNrrd. Holds one file descriptor until committed or dropped.
Result<std::unique_ptr<AtomicFileWriter>> PrepareNrrd(const std::string& path, int dimension,
                                                      std::array<uint32_t, 4> dims,
                                                      VoxelType type,
                                                      std::span<const double> values,
                                                      std::array<double, 4> spacing,
                                                      NrrdOrigin origin);

// The detached form: the voxels as a headerless file `raw_path` and a NRRD
// header `nhdr_path` whose "data file:" names it (relative to the header's
// directory when the raw file is in it or below, absolute otherwise). The
// raw file is written (atomically) before the header, so a header never
// names a missing or half-written raw file. Same checks and errors as
// WriteNrrd.
Status WriteRawWithNhdr(const std::string& raw_path, const std::string& nhdr_path,
                        int dimension, std::array<uint32_t, 4> dims,
                        VoxelType type, std::span<const double> values,
                        std::array<double, 4> spacing = {1, 1, 1, 1},
                        NrrdOrigin origin = std::nullopt);

}  // namespace simplexdb
