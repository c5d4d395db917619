// Input volumes: where a scalar field on a regular 3D or 4D grid is stored on
// disk, and a reader that streams its voxels as doubles.
//
// Formats:
//   raw      headerless voxels; the caller gives dims, type, byte order and
//            the byte offset (OpenRawVolume).
//   NRRD     attached (.nrrd) and detached (.nhdr + "data file:") headers,
//            encodings raw and gzip, either byte order (OpenNrrd).
//   NIfTI-1  single-file .nii (magic "n+1"), either byte order (OpenNifti).
//   time series  several 3D volumes of any of these formats read as one 4D
//            volume (OpenTimeSeries).
//
// The Open* functions read only headers and file sizes: they return a
// VolumeInfo describing the grid and where its bytes are, and check
// everything they can without reading the voxels. VolumeReader then reads
// voxels. Grid rules shared by every format:
//   - 3D or 4D; every used axis has at least 2 samples (the hierarchies need
//     an edge in every direction); unused axes (t of a 3D volume) are 1.
//   - A 4D volume with a single time step (NIfTI dim[0] = 4 with dim[4] = 1,
//     NRRD sizes "... 1", raw dims with t = 1) is read as 3D: a 4D hierarchy
//     needs at least two time steps, and such files are common.
//   - x varies fastest, then y, z, t.
//
// Errors (Status codes) returned by the Open* functions; every message
// starts with the file name:
//   NotFound         a named file does not exist.
//   (errno)          any other failure of the operating system to open,
//                    stat or read a file (permissions, a path through a
//                    non-directory, a directory named as a file, I/O
//                    errors) has the code and words of io's one errno
//                    table, StatusFromErrno in storage/io/file.h (IOError
//                    for an I/O error).
//   InvalidArgument  malformed input: bad magic or header field, bad dims, a
//                    raw file too short for the dims the caller gave.
//   Corruption       a header is well formed but its data file is shorter
//                    than the header says, or not gzip data when it should be,
//                    or gzip data too short to hold the size claimed (more
//                    than 1032 times its bytes, deflate's maximum ratio).
//   NotSupported     well-formed input outside what SimplexDB reads: other
//                    voxel types (int32, RGB, ...), NRRD text/hex/bzip2
//                    encodings, NIfTI-2, 2D or 5D grids.
//
// Thread safety: the Open* functions are reentrant. A VolumeReader is not
// thread-safe; open one per thread.
//
// Lifetimes: a VolumeInfo is a plain value; the Open* functions return it by
// value and keep no file open. VolumeReader::Open hands the caller a
// unique_ptr; the reader keeps its own copy of the VolumeInfo (info() lives
// as long as the reader) and one data file open at a time, closed when it
// moves to another file or is destroyed. The data files are opened again by
// each reader, so a file changed after Open* is read as it is then (a file
// that shrank is Corruption when read).
//
// Where the code is: the grid rules and the checks every reader shares in
// volume_info.cc; one file per format (raw_reader.cc, nrrd_reader.cc,
// nifti_reader.cc), time_series.cc, open_volume.cc (OpenVolume) and
// volume_reader.cc (VolumeReader). Files are read through io's
// ReadOnlyFile (storage/io/read_only_file.h).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

namespace volume_internal {
class ByteSource;  // one open data file, raw or gzip (volume_reader.cc)
}  // namespace volume_internal

// A volume on disk: its grid and where and how its voxels are stored.
//
// Invariants (established by the Open* functions):
//   - dimension is 3 or 4; dims[i] >= 2 for i < dimension, dims[i] == 1 above.
//   - `files` is not empty; each file holds voxel_count() / files.size()
//     consecutive voxels (one file, or one per time step, or one per z slice
//     as NRRD "data file: LIST" allows), x fastest within each.
//   - file_offsets is empty (every file's voxels start at `offset`) or has
//     one entry per file (a time series of files with different headers).
class FieldGenerator;  // storage/volume/generate.h

struct VolumeInfo {
  // kMemory: no data files; `memory` holds the voxels (MemoryVolume).
  // kGenerated: no data files; `generator` computes the voxels of any range
  // (GeneratedVolume, storage/volume/generate.h).
  enum class Encoding : uint8_t { kRaw, kGzip, kMemory, kGenerated };

  int dimension = 3;                          // 3 or 4
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};  // x fastest, then y, z, t; unused = 1
  VoxelType type = VoxelType::kU8;
  ByteOrder order = ByteOrder::kLittle;
  // kGzip: each data file holds, from its offset on, one gzip stream whose
  // decompressed bytes are the voxels.
  Encoding encoding = Encoding::kRaw;
  std::vector<std::string> files;
  // Bytes to skip at the start of each data file (a header). For gzip, the
  // offset of the compressed stream.
  uint64_t offset = 0;
  // Per-file offsets, replacing `offset` when not empty (OpenTimeSeries of
  // files whose headers differ in length). Use offset_of().
  std::vector<uint64_t> file_offsets;
  // kMemory only: voxel_count() voxels of `type` in `order`, x fastest, at
  // memory.get(); `files` is then empty. Shared, not owned: whoever made the
  // VolumeInfo keeps the bytes alive and unchanged while any copy of it (a
  // VolumeReader's too) is in use; the deleter says how (MemoryVolume).
  std::shared_ptr<const std::byte> memory;
  // kGenerated only: the field, each voxel rounded to `type` as `simplexdb
  // generate` writes it; `files` is then empty.
  std::shared_ptr<const FieldGenerator> generator;
  // Physical placement of grid point i on axis a: origin[a] + i * spacing[a]
  // (axis 3 is time). Metadata for the stores' headers: the readers never
  // use them. Unknown: spacing 1, origin 0. A negative spacing (x, y or z
  // only; time runs forwards) is a flipped axis: voxel i lies i * |spacing|
  // before the origin, as NIfTI's qfac -1 and radiological x say. Units are not kept: NIfTI
  // values are converted to millimetres and seconds (xyzt_units), NRRD and
  // raw values are in whatever units the file or the caller used.
  std::array<double, 4> spacing = {1, 1, 1, 1};
  std::array<double, 4> origin = {0, 0, 0, 0};
  // What the reader read but the placement above cannot say, for the
  // store's source ("oblique orientation dropped: ..."); empty when nothing
  // was dropped. SimplexDB grids are axis-aligned: a flip is kept (negative
  // spacing); an oblique orientation keeps its nearest axis-aligned one
  // (each axis's flip, the origin where voxel 0 is, the axes' lengths as
  // spacing) and says here how many degrees of rotation it dropped; a
  // permutation keeps the lengths and the origin, every axis forwards.
  std::string dropped;
  // Values are scale * stored + shift (NIfTI scl_slope and scl_inter);
  // VolumeReader applies them. Identity (1, 0) for every other format.
  double scale = 1;
  double shift = 0;
  std::string description;  // e.g. "NIfTI-1 file example4d.nii", for messages

  // Product of the dims. O(1).
  uint64_t voxel_count() const;
  // Voxels in each data file: voxel_count() / files.size().
  // REQUIRES: !files.empty().
  uint64_t voxels_per_file() const;
  // Where the voxels of files[i] start. REQUIRES: i < files.size().
  uint64_t offset_of(size_t i) const;
  // True when scale/shift change the stored values: the values are then
  // not of `type` but doubles (stores keep them as float32 or float64).
  bool scaled() const { return scale != 1 || shift != 0; }
};

// "128x96x24x2" (the used axes only).
std::string FormatDims(int dimension, const std::array<uint32_t, 4>& dims);

// "slope 2.5, intercept -1" (the shortest text of each that reads back
// exactly): a volume's scale and shift, for messages.
std::string FormatScaling(const VolumeInfo& info);

// What a store records as its source: the description, with its scaling
// when it has one: "NIfTI-1 file a.nii (scaled: slope 2.5, intercept -1)",
// and what its reader dropped ("; oblique orientation dropped: ...").
std::string DescribeSource(const VolumeInfo& info);

// Checks the grid rules above for a volume named `what` (prefixed to the
// message): InvalidArgument for dims of 0 or 1 in a used axis, unused axes
// other than 1, or a dimension other than 3 or 4.
Status ValidateGrid(const std::string& what, int dimension,
                    const std::array<uint32_t, 4>& dims);

// A headerless file of dims[0] * ... * dims[3] voxels of `type` in `order`,
// starting `offset` bytes into the file, and nothing after them. A file of
// another size is InvalidArgument naming the file, the bytes expected and
// the bytes found (the file is truncated, or the dims or type given are
// wrong: a longer file would import as a garbled volume). O(1): stats the
// file.
Result<VolumeInfo> OpenRawVolume(const std::string& path, int dimension,
                                 std::array<uint32_t, 4> dims, VoxelType type,
                                 ByteOrder order, uint64_t offset);

// Voxels already in memory (a numpy array from Python): `bytes` holds
// dims[0] * ... * dims[3] voxels of `type` in `order`, x fastest, and is
// read in place, never copied. `description` names the volume in messages
// and as the store's source. InvalidArgument for a grid that breaks the
// rules above or a null `bytes`; NotSupported for an invalid voxel type.
// The caller vouches for the size: nothing here can check it. O(1).
Result<VolumeInfo> MemoryVolume(int dimension, std::array<uint32_t, 4> dims, VoxelType type,
                                ByteOrder order, std::shared_ptr<const std::byte> bytes,
                                std::string description);

// A NRRD file: attached header (.nrrd, data after the first blank line) or
// detached (.nhdr, any extension really, with "data file:" naming one file,
// "LIST" of files, or a "%d" format with min max step; relative names are
// relative to the header's directory). Encodings raw and gzip (bzip2, text,
// hex: NotSupported). "type:" in any spelling of the NRRD specification.
// "endian:" is required for multi-byte types. "line skip:" and "byte skip:"
// are honoured ("byte skip: -1", data at the end of the file, for raw only;
// a non-zero byte skip with gzip is NotSupported). "kinds:" other than
// domain/space/time/list/none (e.g. "3-vector", "RGB-color") are
// NotSupported: SimplexDB reads scalar fields. Spacing of an axis comes
// from the length of its "space directions:" vector, else from "spacings:"
// (so "space directions: (2,0,0) (0,2,0) (0,0,2) none" with "spacings: nan
// nan nan 0.5" gives a time step of 0.5). Origin comes from "space origin:"
// (the space axes) and "axis mins:" (every axis "space origin:" does not
// give). A direction along its own axis backwards, (0,-2,0) for y, is a
// flip: spacing -2. Directions that are turned from the axes keep their
// nearest axis-aligned orientation, and a permutation (or a space other
// than 3D) keeps their lengths only; VolumeInfo::dropped says what went.
// "space units:" are not kept. Other fields and key/value pairs
// are ignored, as the specification asks of readers that do not use them.
// For gzip, the gzip trailer (size mod 2^32) is checked against the
// expected size, and n bytes of gzip data may claim at most 1032 n bytes
// (deflate's maximum ratio); the stream itself is only checked when read.
// Data files are checked as they are named, so a "%d" format naming
// millions of files fails at the first missing or short one, and its count
// is checked against the sizes before any name is made.
// O(header size + lines skipped + data files).
Result<VolumeInfo> OpenNrrd(const std::string& path);

// A single-file NIfTI-1 volume (.nii, magic "n+1"). The byte order is the
// one in which sizeof_hdr reads 348. Datatypes: 2 uint8, 4 int16, 16 float32,
// 64 float64, 256 int8, 512 uint16; others (int32, RGB, complex, ...) are
// NotSupported naming the code. dim[0] must be 3 or 4 (higher with trailing
// dims of 1). Voxels start at vox_offset (>= 352). scl_slope and scl_inter
// scale the values as the NIfTI-1 standard says: value = scl_slope * stored
// + scl_inter, unless scl_slope is 0 (no scaling); a slope that is not
// finite means no scaling and an intercept that is not finite means 0 (as
// nibabel reads them). They become VolumeInfo::scale and shift. Spacing
// is |pixdim[1..4]|, negated for an axis the matrix below flips; origin
// the sform's translation when sform_code > 0,
// else the qform's (qoffset_x, y, z) when qform_code > 0, else 0 (NIfTI
// method 1); origin[3] is toffset. Lengths are converted to millimetres and
// times to seconds by xyzt_units (unknown units: as stored), so a TR of
// 2000 with units ms is spacing[3] = 2 (the shared example4d.nii says
// seconds for its 2000 ms TR: 2000, as its header says). The chosen
// matrix (sform, else qform with qfac) places the grid: a flip (a negative
// diagonal entry, such as the usual radiological x, or qfac -1 for z) is
// kept as a negative spacing; a rotation keeps the nearest axis-aligned
// orientation and a permutation none, and VolumeInfo::dropped says what
// was dropped (SimplexDB grids are axis-aligned). Both shared NIfTI files
// are oblique: the fMRI by 9.3 degrees about x, with x flipped.
// .nii.gz is not read (NotSupported from OpenVolume: gunzip it first).
// O(1): reads the 348-byte header.
Result<VolumeInfo> OpenNifti(const std::string& path);

// Several 3D volumes (each opened with OpenVolume, any mix of formats) of
// equal dims, type, byte order and encoding, as one 4D volume whose time
// axis is their order in `paths`. Spacing and origin are the first
// volume's (time step 1, time origin 0).
// Fails with InvalidArgument naming the first mismatching file, the value
// found and the value expected, or if fewer than 2 paths are given.
Result<VolumeInfo> OpenTimeSeries(const std::vector<std::string>& paths);

// By extension (case-insensitive): .nrrd/.nhdr -> OpenNrrd, .nii ->
// OpenNifti. .nii.gz and .hdr/.img pairs: NotSupported saying what to do.
// Anything else: InvalidArgument saying that raw input needs --dims and
// --type.
Result<VolumeInfo> OpenVolume(const std::string& path);

// Streams voxels as doubles (lossless for all six types), scaled by
// VolumeInfo::scale and shift when scaled(). Values are returned as they are
// (NaN, infinities, any float64); builders check what a store can hold
// (storage/error/field_values.h).
//
// Sequential reads are the fast path: raw files are read through a 1 MiB
// read-ahead buffer (so reading x-rows one by one costs about one system
// call per MiB), gzip streams are decompressed once front to back. Random
// access works too: a raw read outside the buffer costs one pread; a gzip
// read behind the current position rewinds and decompresses again from the
// start of the stream (O(position)), ahead of it decompresses the gap.
// One data file is open at a time; reads alternating between the files of
// a multi-file volume reopen them each time.
//
// Not thread-safe; open one per thread.
class VolumeReader {
 public:
  // Checks the invariants of `info` (InvalidArgument otherwise; NotSupported
  // for an invalid voxel type) and opens its first data file (NotFound, the
  // errno table's Status for another failure to open it, Corruption for
  // gzip data that is not gzip). The reader keeps its own copy of `info`.
  static Result<std::unique_ptr<VolumeReader>> Open(const VolumeInfo& info);

  ~VolumeReader();
  VolumeReader(const VolumeReader&) = delete;
  VolumeReader& operator=(const VolumeReader&) = delete;

  // Reads `count` voxels starting at linear index `first` (x fastest, then
  // y, z, t) into out[0 .. count). Fails with Corruption naming the file on
  // a short read (the file shrank since it was opened, a truncated gzip
  // stream) or a gzip error, the errno table's Status on an
  // operating-system error (IOError for an I/O error), and
  // InvalidArgument if [first, first + count) is not inside the volume.
  // After a failure `out` holds unspecified values and the reader can be
  // used again. REQUIRES: `out` holds count doubles.
  Status Read(uint64_t first, size_t count, double* out);

  const VolumeInfo& info() const { return info_; }

 private:
  explicit VolumeReader(VolumeInfo info);
  // Makes files[file] the open source.
  Status OpenFile(size_t file);
  bool FileLess() const;

  VolumeInfo info_;
  uint64_t per_file_ = 0;  // voxels per data file
  size_t current_file_ = 0;
  std::unique_ptr<volume_internal::ByteSource> source_;  // null: none open
  std::vector<std::byte> bytes_;        // voxel bytes of one chunk
};

}  // namespace simplexdb
