// What every volume reader does to the VolumeInfo it returns (internal to
// storage/volume): the grid rules and the data-file checks of volume.h,
// shared by the raw, NRRD and NIfTI-1 readers and time series. Not part of
// the API; no caller outside storage/volume should include it.
//
// Thread safety: reentrant (no shared state); CheckDataFiles opens files.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb::volume_internal {

// A 4D grid with one time step is read as 3D (see volume.h): sets
// dimension 3, spacing[3] 1 and origin[3] 0 when dimension is 4 and
// dims[3] is 1.
void DropSingleTimeStep(VolumeInfo& info);

// The description of a grid of `type` voxels in `order`, for the readers
// whose caller gives it (raw files, voxels in memory); `name` names it in
// messages. NotSupported for a type that is not one of the six; then the
// single time step dropped and ValidateGrid's checks.
Result<VolumeInfo> DescribeGrid(const std::string& name, int dimension,
                                std::array<uint32_t, 4> dims, VoxelType type, ByteOrder order);

// Checks that every data file of `info` exists, is readable and is long
// enough for its voxels after its offset (raw), or starts gzip data at its
// offset whose trailer gives the expected size mod 2^32 and is large enough
// to decompress to it at deflate's maximum ratio, 1032:1 (gzip). Errors:
// those of ReadOnlyFile (storage/io/read_only_file.h; a missing file is
// NotFound); `truncated(message)` for a raw file too short (its code
// differs: the caller's dims for raw input, a corrupt file for a header
// format); Corruption for gzip data that is not gzip, too short or of the
// wrong size. Messages about a data file other than the file the user named
// end with " (data file of <info.description>)".
// REQUIRES: !info.files.empty(). Cost: one open, one fstat (and two small
// preads for gzip) per data file.
Status CheckDataFiles(const VolumeInfo& info, Status (*truncated)(std::string_view));

// CheckDataFiles for one data file, `path`, whose voxels start at `offset`,
// of `file_count` that split info's voxels evenly: for a reader that checks
// each file as it learns its name (a NRRD "data file:" format naming
// millions), and so fails at the first missing or short one.
// REQUIRES: file_count > 0.
Status CheckDataFile(const VolumeInfo& info, uint64_t file_count, const std::string& path,
                     uint64_t offset, Status (*truncated)(std::string_view));

// `truncated` for CheckDataFiles: raw input, whose size is the caller's
// (InvalidArgument, "... truncated, or the dims or type given are wrong").
Status TruncatedRaw(std::string_view msg);
// `truncated` for CheckDataFiles: a header format, whose data file is short
// (Corruption, "...: the data file is truncated").
Status TruncatedData(std::string_view msg);

// Sets info.offset and info.file_offsets from one offset per data file,
// keeping just info.offset when all are the same, as in most volumes.
void SetOffsets(VolumeInfo& info, std::vector<uint64_t> offsets);

// What an axis-aligned grid keeps of an orientation: grid axis c runs
// along space axis c, forwards (sign +1) or backwards (-1, a flipped axis:
// a NIfTI qfac of -1, a negative sform or NRRD direction entry).
struct AxisAlignment {
  std::array<int, 3> sign = {1, 1, 1};
  // How far the orientation is from that: the largest angle, in degrees,
  // between a grid axis and the space axis it is given (0 when axis-aligned).
  double oblique_degrees = 0;
  // Grid axis c runs nearest to another space axis than c (a permutation,
  // e.g. a sagittal acquisition), or an entry is not finite or an axis has
  // length 0: nothing of the orientation is kept (signs +1).
  bool unusable = false;
  // "flipped y, z", "" when no axis is: for messages.
  std::string FlippedAxes() const;
};

// The nearest axis-aligned orientation of `axes`, whose c-th entry is grid
// axis c's direction in space (any length; a NIfTI matrix's columns, the
// NRRD "space directions:" vectors), as radiology viewers place an oblique
// volume: each grid axis keeps the sign of its own space component.
// REQUIRES: each axes[c] has 3 entries. O(1).
AxisAlignment NearestAxisAlignment(const std::array<std::array<double, 3>, 3>& axes);

// The text VolumeInfo::dropped gets for an orientation that is not exactly
// axis-aligned ("" when it is): `source` names the matrix ("the NIfTI
// sform"), `alignment` is what NearestAxisAlignment kept.
std::string DescribeDroppedOrientation(const std::string& source, const AxisAlignment& alignment);

}  // namespace simplexdb::volume_internal
