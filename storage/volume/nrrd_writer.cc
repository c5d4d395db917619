#include "storage/volume/nrrd_writer.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string_view>
#include <system_error>
#include <vector>

#include "storage/io/file.h"
#include "storage/volume/writer_internal.h"

namespace simplexdb {

namespace volume_internal {

std::string FormatDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

Status CheckImage(const std::string& path, int dimension, const std::array<uint32_t, 4>& dims,
                  VoxelType type, std::span<const double> values,
                  const std::array<double, 4>& spacing,
                  const std::optional<std::array<double, 3>>& origin) {
  if (origin && !std::all_of(origin->begin(), origin->end(),
                             [](double v) { return std::isfinite(v); })) {
    return Status::InvalidArgument(path + ": the origin must be finite");
  }
  if (!IsValidVoxelType(type)) {
    return Status::InvalidArgument(path + ": voxel type code " +
                                   std::to_string(static_cast<int>(type)) +
                                   " is not one of the six types");
  }
  if (dimension != 3 && dimension != 4) {
    return Status::InvalidArgument(path + ": dimension " + std::to_string(dimension) +
                                   ", expected 3 or 4");
  }
  uint64_t count = 1;
  for (int i = 0; i < 4; ++i) {
    const auto a = static_cast<size_t>(i);
    if (i < dimension && dims[a] < 1) {
      return Status::InvalidArgument(path + ": axis " + "xyzt"[i] + " has 0 samples");
    }
    if (i >= dimension && dims[a] != 1) {
      return Status::InvalidArgument(path + ": unused axis " + "xyzt"[i] + " has " +
                                     std::to_string(dims[a]) + " samples, expected 1");
    }
    // Positive: VTK's NRRD reader (so ParaView) takes a space direction's
    // length and drops its sign; callers write a flipped axis reversed.
    if (i < dimension && !(std::isfinite(spacing[a]) && spacing[a] > 0)) {
      return Status::InvalidArgument(path + ": spacing " + FormatDouble(spacing[a]) +
                                     " along " + "xyzt"[i] +
                                     ", expected a positive finite number");
    }
    count *= dims[a];
  }
  if (values.size() != count) {
    return Status::InvalidArgument(path + ": " + std::to_string(values.size()) +
                                   " values for " + std::to_string(count) + " voxels");
  }
  const auto bad = std::find_if(values.begin(), values.end(), [&](double v) {
    return !IsRepresentable(type, v);
  });
  if (bad != values.end()) {
    return Status::InvalidArgument(
        path + ": value " + FormatDouble(*bad) + " at voxel " +
        std::to_string(bad - values.begin()) + " is not representable as " +
        std::string(VoxelTypeName(type)) + " (round or clamp it first)");
  }
  return Status::OK();
}

Status AppendVoxels(AtomicFileWriter& file, VoxelType type,
                    std::span<const double> values) {
  constexpr size_t kChunk = 64 * 1024;  // voxels per write
  std::vector<std::byte> bytes;
  for (size_t i = 0; i < values.size(); i += kChunk) {
    const size_t n = std::min(kChunk, values.size() - i);
    bytes.resize(n * VoxelSize(type));
    EncodeVoxels(type, ByteOrder::kLittle, values.data() + i, n, bytes.data());
    SDB_ASSIGN_OR_RETURN(
        const uint64_t at,
        file.Append({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}));
    (void)at;
  }
  return Status::OK();
}

}  // namespace volume_internal

namespace {

using volume_internal::CheckImage;
using volume_internal::FormatDouble;

// The header up to and including its last field line.
// With an origin: the space fields for x, y, z instead of "spacings:" (the
// specification allows one or the other per axis), and a 4D file's time
// axis in "spacings:" with "nan" for the space axes.
std::string NrrdHeader(int dimension, const std::array<uint32_t, 4>& dims,
                       VoxelType type, const std::array<double, 4>& spacing,
                       const NrrdOrigin& origin) {
  std::string sizes, spacings, kinds, directions;
  for (int i = 0; i < dimension; ++i) {
    const auto a = static_cast<size_t>(i);
    if (i > 0) {
      sizes += ' ';
      spacings += ' ';
      kinds += ' ';
      directions += ' ';
    }
    sizes += std::to_string(dims[a]);
    kinds += "domain";
    if (i < 3) {
      directions += '(';
      for (int j = 0; j < 3; ++j) {
        directions += (j > 0 ? "," : "") + FormatDouble(i == j ? spacing[a] : 0.0);
      }
      directions += ')';
      // An axis with a direction has no spacing of its own.
      spacings += origin ? "nan" : FormatDouble(spacing[a]);
    } else {
      directions += "none";  // time: not a space axis
      spacings += FormatDouble(spacing[a]);
    }
  }
  std::string h = "NRRD0004\n# Written by SimplexDB.\n";
  h += "type: " + std::string(NrrdTypeName(type)) + "\n";
  h += "dimension: " + std::to_string(dimension) + "\n";
  if (origin) h += "space dimension: 3\n";
  h += "sizes: " + sizes + "\n";
  if (origin) {
    h += "space directions: " + directions + "\n";
    h += "space origin: (" + FormatDouble((*origin)[0]) + "," + FormatDouble((*origin)[1]) + "," +
         FormatDouble((*origin)[2]) + ")\n";
  }
  // With the space fields, only a 4D file's time axis has a spacing left.
  if (!origin || dimension == 4) h += "spacings: " + spacings + "\n";
  h += "kinds: " + kinds + "\n";
  // "endian:" is required exactly when the type has more than one byte.
  if (VoxelSize(type) > 1) h += "endian: little\n";
  h += "encoding: raw\n";
  return h;
}

// The "data file:" value naming `raw_path` from the header `nhdr_path`.
Result<std::string> DataFileName(const std::string& raw_path,
                                 const std::string& nhdr_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path raw = fs::absolute(raw_path, ec).lexically_normal();
  if (ec) return StatusFromErrno(ec.value(), raw_path, "make an absolute path of");
  const fs::path dir = fs::absolute(nhdr_path, ec).lexically_normal().parent_path();
  if (ec) return StatusFromErrno(ec.value(), nhdr_path, "make an absolute path of");
  const fs::path rel = raw.lexically_relative(dir);
  const std::string name =
      !rel.empty() && *rel.begin() != ".." ? rel.string() : raw.string();
  // A name a NRRD reader would take for something else.
  if (name.find_first_of("\r\n") != std::string::npos || name.rfind("LIST", 0) == 0 ||
      name.front() == ' ' || name.back() == ' ') {
    return Status::InvalidArgument(raw_path +
                                   ": this name cannot be written in a NRRD "
                                   "'data file:' field");
  }
  return name;
}

}  // namespace

Result<std::unique_ptr<AtomicFileWriter>> PrepareNrrd(const std::string& path, int dimension,
                                                      std::array<uint32_t, 4> dims,
                                                      VoxelType type,
                                                      std::span<const double> values,
                                                      std::array<double, 4> spacing,
                                                      NrrdOrigin origin) {
  SDB_RETURN_IF_ERROR(CheckImage(path, dimension, dims, type, values, spacing, origin));
  // A blank line ends an attached header; the voxels follow it.
  const std::string header = NrrdHeader(dimension, dims, type, spacing, origin) + "\n";
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<AtomicFileWriter> file, AtomicFileWriter::Create(path));
  SDB_ASSIGN_OR_RETURN(const uint64_t at, file->Append(header));
  (void)at;
  SDB_RETURN_IF_ERROR(volume_internal::AppendVoxels(*file, type, values));
  return file;
}

Status WriteNrrd(const std::string& path, int dimension,
                 std::array<uint32_t, 4> dims, VoxelType type,
                 std::span<const double> values, std::array<double, 4> spacing,
                 NrrdOrigin origin) {
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<AtomicFileWriter> file,
                       PrepareNrrd(path, dimension, dims, type, values, spacing, origin));
  return file->Commit();
}

Status WriteRawWithNhdr(const std::string& raw_path, const std::string& nhdr_path,
                        int dimension, std::array<uint32_t, 4> dims,
                        VoxelType type, std::span<const double> values,
                        std::array<double, 4> spacing, NrrdOrigin origin) {
  SDB_RETURN_IF_ERROR(CheckImage(nhdr_path, dimension, dims, type, values, spacing, origin));
  SDB_ASSIGN_OR_RETURN(const std::string data_file, DataFileName(raw_path, nhdr_path));
  {
    SDB_ASSIGN_OR_RETURN(std::unique_ptr<AtomicFileWriter> raw, AtomicFileWriter::Create(raw_path));
    SDB_RETURN_IF_ERROR(volume_internal::AppendVoxels(*raw, type, values));
    SDB_RETURN_IF_ERROR(raw->Commit());
  }
  const std::string header =
      NrrdHeader(dimension, dims, type, spacing, origin) + "data file: " + data_file + "\n";
  return WriteFileAtomically(nhdr_path, header);
}

}  // namespace simplexdb
