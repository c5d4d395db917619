#include "storage/volume/volume.h"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include "storage/io/read_only_file.h"
#include "storage/volume/text_internal.h"
#include "storage/volume/volume_info_internal.h"

namespace simplexdb {

// ---------------------------------------------------------------------------
// VolumeInfo and the grid rules (volume.h).

uint64_t VolumeInfo::voxel_count() const {
  return uint64_t{dims[0]} * dims[1] * dims[2] * dims[3];
}

uint64_t VolumeInfo::voxels_per_file() const {
  assert(!files.empty());
  return voxel_count() / files.size();
}

uint64_t VolumeInfo::offset_of(size_t i) const {
  assert(i < files.size());
  return file_offsets.empty() ? offset : file_offsets[i];
}

std::string FormatDims(int dimension, const std::array<uint32_t, 4>& dims) {
  std::string s;
  for (int i = 0; i < dimension && i < 4; ++i) {
    if (i > 0) s.push_back('x');
    s += std::to_string(dims[static_cast<size_t>(i)]);
  }
  return s;
}

std::string FormatScaling(const VolumeInfo& info) {
  const auto shortest = [](double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof(buf), v);
    return std::string(buf, r.ptr);
  };
  return "slope " + shortest(info.scale) + ", intercept " + shortest(info.shift);
}

std::string DescribeSource(const VolumeInfo& info) {
  std::string s = info.scaled() ? info.description + " (scaled: " + FormatScaling(info) + ")"
                                : info.description;
  if (!info.dropped.empty()) s += "; " + info.dropped;
  return s;
}

Status ValidateGrid(const std::string& what, int dimension,
                    const std::array<uint32_t, 4>& dims) {
  if (dimension != 3 && dimension != 4) {
    return Status::InvalidArgument(what + ": dimension " + std::to_string(dimension) +
                                   ", expected 3 or 4");
  }
  for (int i = 0; i < 4; ++i) {
    const uint32_t d = dims[static_cast<size_t>(i)];
    if (i < dimension && d < 2) {
      return Status::InvalidArgument(
          what + ": dims " + FormatDims(dimension, dims) + ": axis " + "xyzt"[i] +
          " has " + std::to_string(d) + " samples, expected at least 2");
    }
    if (i >= dimension && d != 1) {
      return Status::InvalidArgument(what + ": a " + std::to_string(dimension) +
                                     "D volume with " + std::to_string(d) +
                                     " samples along unused axis " + "xyzt"[i] +
                                     ", expected 1");
    }
  }
  // Keep byte counts well inside uint64_t: at most 2^60 voxels.
  uint64_t n = 1;
  for (uint32_t d : dims) {
    if (n > (uint64_t{1} << 60) / d) {
      return Status::InvalidArgument(what + ": dims " + FormatDims(dimension, dims) +
                                     " exceed 2^60 voxels");
    }
    n *= d;
  }
  return Status::OK();
}

namespace volume_internal {
namespace {

using Encoding = VolumeInfo::Encoding;

// " (data file of NRRD header h.nhdr)" when the data file is not the file
// the user named, so a message about it leads back to what they opened.
std::string DataFileContext(const VolumeInfo& info, const std::string& path) {
  const std::string& d = info.description;
  if (d.empty() || (d.size() >= path.size() &&
                    d.compare(d.size() - path.size(), path.size(), path) == 0)) {
    return std::string();
  }
  return " (data file of " + d + ")";
}

}  // namespace

// ---------------------------------------------------------------------------
// Checks shared by every reader (volume_info_internal.h).

void DropSingleTimeStep(VolumeInfo& info) {
  if (info.dimension == 4 && info.dims[3] == 1) {
    info.dimension = 3;
    info.spacing[3] = 1;
    info.origin[3] = 0;
  }
}

Result<VolumeInfo> DescribeGrid(const std::string& name, int dimension,
                                std::array<uint32_t, 4> dims, VoxelType type, ByteOrder order) {
  if (!IsValidVoxelType(type)) {
    return Status::NotSupported(name + ": voxel type code " + std::to_string(static_cast<int>(type)) +
                                " is not one of the six supported types");
  }
  VolumeInfo info;
  info.dimension = dimension;
  info.dims = dims;
  info.type = type;
  info.order = order;
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(name, info.dimension, info.dims));
  return info;
}

Status CheckDataFiles(const VolumeInfo& info,
                      Status (*truncated)(std::string_view)) {
  for (size_t i = 0; i < info.files.size(); ++i) {
    SDB_RETURN_IF_ERROR(
        CheckDataFile(info, info.files.size(), info.files[i], info.offset_of(i), truncated));
  }
  return Status::OK();
}

Status CheckDataFile(const VolumeInfo& info, uint64_t file_count, const std::string& path,
                     uint64_t offset, Status (*truncated)(std::string_view)) {
  const uint64_t bytes_per_file = info.voxel_count() / file_count * VoxelSize(info.type);
  Result<ReadOnlyFile> opened = ReadOnlyFile::Open(path);
  if (!opened.ok()) {
    return WithMessage(opened.status(), std::string(opened.status().message()) +
                                            DataFileContext(info, path));
  }
  const ReadOnlyFile file = std::move(opened).value();
  SDB_ASSIGN_OR_RETURN(const uint64_t size, file.Size());
  if (info.encoding == Encoding::kRaw) {
    // Bytes after the voxels are trailing data we ignore (see volume.h).
    if (size < offset || size - offset < bytes_per_file) {
      const std::string what =
          file_count == 1
              ? FormatDims(info.dimension, info.dims)
              : std::to_string(info.voxel_count() / file_count) + " voxels (one of " +
                    std::to_string(file_count) + " files of " +
                    FormatDims(info.dimension, info.dims) + ")";
      // offset + bytes_per_file may not fit 64 bits (an offset given by hand).
      const std::string expected =
          offset > std::numeric_limits<uint64_t>::max() - bytes_per_file
              ? "more than 2^64 - 1"
              : "at least " + std::to_string(offset + bytes_per_file);
      return truncated(
          path + ": has " + std::to_string(size) + " bytes, expected " + expected +
          " (" + what + " " +
          std::string(VoxelTypeName(info.type)) + " = " +
          std::to_string(bytes_per_file) + " bytes after offset " +
          std::to_string(offset) + ")" + DataFileContext(info, path));
    }
    return Status::OK();
  }
  // gzip: magic at the offset, and the trailer's ISIZE (uncompressed size
  // mod 2^32, RFC 1952) must match. A truncated stream almost surely ends
  // in other bytes; the stream itself is checked when read.
  constexpr uint64_t kMinGzip = 18;  // 10-byte header + 8-byte trailer
  if (size < offset || size - offset < kMinGzip) {
    return Status::Corruption(path + ": has " + std::to_string(size) +
                              " bytes, too short for gzip data at byte " +
                              std::to_string(offset) + DataFileContext(info, path));
  }
  // A claim no gzip data of this size can meet fails here, before a
  // reader decompresses for minutes: deflate's densest code is a 258-byte
  // match in 2 bits (a 1-bit length code and a 1-bit distance code,
  // RFC 1951 3.2.5), so a stream of n bytes decompresses to at most
  // 1032 n bytes (zlib's documented maximum ratio is 1032:1).
  constexpr uint64_t kMaxDeflateRatio = 1032;
  const uint64_t compressed = size - offset;
  // bytes_per_file > compressed * 1032, without overflow.
  if ((bytes_per_file + kMaxDeflateRatio - 1) / kMaxDeflateRatio > compressed) {
    return Status::Corruption(
        path + ": " + FormatDims(info.dimension, info.dims) + " " +
        std::string(VoxelTypeName(info.type)) + " claims " +
        std::to_string(bytes_per_file) + " decompressed bytes" +
        (file_count == 1 ? std::string()
                                : " per data file (one of " +
                                      std::to_string(file_count) + ")") +
        ", but the file holds " + std::to_string(compressed) +
        " bytes of gzip data, which decompress to at most " +
        std::to_string(compressed * kMaxDeflateRatio) +
        " (deflate's maximum ratio is 1032:1): wrong sizes or truncated" +
        DataFileContext(info, path));
  }
  std::array<std::byte, 4> b{};
  SDB_ASSIGN_OR_RETURN(size_t got, file.ReadUpTo(offset, 2, b.data()));
  if (got != 2 || b[0] != std::byte{0x1f} || b[1] != std::byte{0x8b}) {
    return Status::Corruption(path + ": encoding gzip, but byte " +
                              std::to_string(offset) +
                              " does not start gzip data (magic 1f 8b)" +
                              DataFileContext(info, path));
  }
  SDB_ASSIGN_OR_RETURN(got, file.ReadUpTo(size - 4, 4, b.data()));
  if (got != 4) return Status::IOError(path + ": cannot read the gzip trailer");
  const uint32_t isize = static_cast<uint32_t>(b[0]) |
                         static_cast<uint32_t>(b[1]) << 8 |
                         static_cast<uint32_t>(b[2]) << 16 |
                         static_cast<uint32_t>(b[3]) << 24;
  const auto expected = static_cast<uint32_t>(bytes_per_file);  // mod 2^32
  if (isize != expected) {
    return Status::Corruption(
        path + ": gzip trailer gives " + std::to_string(isize) +
        " bytes (mod 2^32) of decompressed data, expected " +
        std::to_string(bytes_per_file) + " (" +
        FormatDims(info.dimension, info.dims) + " " +
        std::string(VoxelTypeName(info.type)) +
        "): truncated or wrong sizes" + DataFileContext(info, path));
  }
  return Status::OK();
}

Status TruncatedRaw(std::string_view msg) {
  return Status::InvalidArgument(std::string(msg) +
                                 ": truncated, or the dims or type given are wrong");
}
Status TruncatedData(std::string_view msg) {
  return Status::Corruption(std::string(msg) + ": the data file is truncated");
}

void SetOffsets(VolumeInfo& info, std::vector<uint64_t> offsets) {
  const bool same = std::all_of(offsets.begin(), offsets.end(),
                                [&](uint64_t o) { return o == offsets.front(); });
  info.offset = offsets.empty() ? 0 : offsets.front();
  info.file_offsets.clear();
  if (!same) info.file_offsets = std::move(offsets);
}

std::string AxisAlignment::FlippedAxes() const {
  std::string axes;
  for (size_t c = 0; c < 3; ++c) {
    if (sign[c] < 0) axes += std::string(axes.empty() ? "flipped " : ", ") + "xyz"[c];
  }
  return axes;
}

AxisAlignment NearestAxisAlignment(const std::array<std::array<double, 3>, 3>& axes) {
  AxisAlignment a;
  for (size_t c = 0; c < 3; ++c) {
    const std::array<double, 3>& v = axes[c];
    double length2 = 0;
    size_t nearest = 0;
    for (size_t r = 0; r < 3; ++r) {
      if (!std::isfinite(v[r])) a.unusable = true;
      length2 += v[r] * v[r];
      if (std::fabs(v[r]) > std::fabs(v[nearest])) nearest = r;
    }
    if (a.unusable || !(length2 > 0) || !std::isfinite(length2) || nearest != c) {
      return AxisAlignment{.unusable = true};
    }
    a.sign[c] = v[c] < 0 ? -1 : 1;
    const double cosine = std::min(1.0, std::fabs(v[c]) / std::sqrt(length2));
    a.oblique_degrees = std::max(a.oblique_degrees, std::acos(cosine) * 180 / std::numbers::pi);
  }
  return a;
}

std::string DescribeDroppedOrientation(const std::string& source, const AxisAlignment& alignment) {
  // Below a thousandth of a degree the turn is float32 rounding of an
  // aligned matrix (a quaternion's entries), not an oblique acquisition.
  constexpr double kAlignedDegrees = 1e-3;
  if (alignment.unusable) {
    return "orientation dropped: " + source +
           " permutes the axes or is degenerate; spacing is the axes' lengths, origin its "
           "translation, every axis forwards";
  }
  if (alignment.oblique_degrees < kAlignedDegrees) return "";
  char angle[32];
  std::snprintf(angle, sizeof angle, "%.2g", alignment.oblique_degrees);
  const std::string flips = alignment.FlippedAxes();
  return "oblique orientation dropped: " + source + " turns the grid up to " + angle +
         " degrees from the axes; kept the nearest axis-aligned orientation (" +
         (flips.empty() ? std::string("no axis flipped") : flips) + ")";
}

}  // namespace volume_internal
}  // namespace simplexdb
