// Writing a 3D grid as a VTK XML ImageData file (.vti), for `simplexdb
// export -o OUT.pvd`: ParaView's .pvd reader (vtkXMLCollectionReader) opens
// VTK XML files only (.vti, .vtu, ...), not NRRD, so a time series ParaView
// plays is a .pvd of .vti files.
//
// The file: <VTKFile type="ImageData" version="1.0" byte_order="LittleEndian"
// header_type="UInt64">, one Piece covering WholeExtent, the origin and
// spacing given, one point-data array "field" of the voxel type (UInt8, Int8,
// UInt16, Int16, Float32, Float64) in raw appended data: "_", the byte count
// as a little-endian uint64, the voxels x fastest. Written atomically through
// AtomicFileWriter (storage/io/file.h), as the NRRD writer does.
//
// Errors: those of WriteNrrd (storage/volume/nrrd_writer.h) for the same
// input: InvalidArgument for bad dims, a count mismatch, a value not
// representable as `type`, a non-positive spacing or a non-finite origin;
// NotFound, ResourceExhausted, IOError from the file system.
//
// Thread safety: reentrant. Lifetimes: the values are only read during the
// call; PrepareVti hands back the writer, owned by the caller.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "storage/io/file.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// The complete .vti in the temporary of `path`, not yet renamed: Commit()
// puts it in place, dropping the writer removes it (as PrepareNrrd).
// O(voxels).
Result<std::unique_ptr<AtomicFileWriter>> PrepareVti(const std::string& path,
                                                     std::array<uint32_t, 3> dims,
                                                     VoxelType type,
                                                     std::span<const double> values,
                                                     std::array<double, 3> spacing,
                                                     std::array<double, 3> origin);

}  // namespace simplexdb
