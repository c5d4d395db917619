// The NIfTI-1 reader, OpenNifti (volume.h): single-file .nii volumes of
// either byte order, read from their 348-byte header.
#include "storage/volume/volume.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <optional>
#include <string_view>

#include <fmt/format.h>

#include "storage/io/read_only_file.h"
#include "storage/volume/volume_info_internal.h"

namespace simplexdb {
namespace {

using Encoding = VolumeInfo::Encoding;
using volume_internal::CheckDataFiles;
using volume_internal::DropSingleTimeStep;
using volume_internal::TruncatedData;

// Field offsets in the 348-byte NIfTI-1 header (nifti1.h).
constexpr size_t kNiftiHeaderSize = 348;
constexpr size_t kNiftiDim = 40;        // int16 dim[8]
constexpr size_t kNiftiDatatype = 70;   // int16
constexpr size_t kNiftiBitpix = 72;     // int16
constexpr size_t kNiftiPixdim = 76;     // float32 pixdim[8]
constexpr size_t kNiftiVoxOffset = 108; // float32
constexpr size_t kNiftiSclSlope = 112;  // float32
constexpr size_t kNiftiSclInter = 116;  // float32
constexpr size_t kNiftiXyztUnits = 123; // char
constexpr size_t kNiftiToffset = 136;   // float32
constexpr size_t kNiftiQformCode = 252; // int16
constexpr size_t kNiftiSformCode = 254; // int16
constexpr size_t kNiftiQuatern = 256;   // float32 quatern_b, c, d, qoffset_x, y, z
constexpr size_t kNiftiSrow = 280;      // float32 srow_x[4], srow_y[4], srow_z[4]
constexpr size_t kNiftiMagic = 344;     // char[4]

// Reads integers and floats of the header in its byte order.
class NiftiFields {
 public:
  NiftiFields(const std::array<std::byte, kNiftiHeaderSize>& h, ByteOrder order)
      : h_(h), order_(order) {}
  int16_t I16(size_t at) const {
    int16_t v;
    Get(at, &v);
    return v;
  }
  int32_t I32(size_t at) const {
    int32_t v;
    Get(at, &v);
    return v;
  }
  float F32(size_t at) const {
    uint32_t u;
    Get(at, &u);
    return std::bit_cast<float>(u);
  }

 private:
  template <class T>
  void Get(size_t at, T* v) const {
    std::array<std::byte, sizeof(T)> b;
    std::memcpy(b.data(), h_.data() + at, sizeof(T));
    if (order_ != NativeByteOrder()) std::reverse(b.begin(), b.end());
    std::memcpy(v, b.data(), sizeof(T));
  }
  const std::array<std::byte, kNiftiHeaderSize>& h_;
  ByteOrder order_;
};

struct NiftiDatatype {
  int16_t code;
  std::string_view name;
  std::optional<VoxelType> type;
};

// NIfTI-1 datatype codes (nifti1.h, NIFTI_TYPE_*).
constexpr NiftiDatatype kNiftiDatatypes[] = {
    {1, "binary", std::nullopt},         {2, "uint8", VoxelType::kU8},
    {4, "int16", VoxelType::kI16},       {8, "int32", std::nullopt},
    {16, "float32", VoxelType::kF32},    {32, "complex64", std::nullopt},
    {64, "float64", VoxelType::kF64},    {128, "rgb24", std::nullopt},
    {256, "int8", VoxelType::kI8},       {512, "uint16", VoxelType::kU16},
    {768, "uint32", std::nullopt},       {1024, "int64", std::nullopt},
    {1280, "uint64", std::nullopt},      {1536, "float128", std::nullopt},
    {1792, "complex128", std::nullopt},  {2048, "complex256", std::nullopt},
    {2304, "rgba32", std::nullopt},
};

// Millimetres per unit of xyzt_units' space code, seconds per unit of its
// time code (nifti1.h NIFTI_UNITS_*); 1 for unknown (0) or other codes, so
// the values stay as stored.
double NiftiSpaceToMm(int units) {
  switch (units & 0x07) {
    case 1: return 1000;   // metre
    case 3: return 0.001;  // micron
    default: return 1;     // 2: mm; 0: unknown
  }
}
double NiftiTimeToSeconds(int units) {
  switch (units & 0x38) {
    case 16: return 0.001;  // msec
    case 24: return 1e-6;   // usec
    default: return 1;      // 8: sec; 0: unknown; Hz, ppm, rad/s: as stored
  }
}

// NIfTI-1's transform codes: 0 unknown, 1 scanner, 2 aligned, 3 Talairach,
// 4 MNI 152 (nifti1.h, NIFTI_XFORM_*). Another is not a transform this
// reader knows how to take.
constexpr int16_t kNiftiLastXform = 4;

// Places the grid by NIfTI-1's "3 methods" (nifti1.h), sform first as
// nibabel and ITK do:
//   method 3 (sform_code 1-4): grid point (i, j, k) is at srow x (i, j, k,
//     1): each axis's spacing is the length of its column, the origin the
//     translation;
//   method 2 (qform_code 1-4): the rotation of the quaternion (b, c, d), a
//     = sqrt(1 - b^2 - c^2 - d^2), with qfac = pixdim[0] (-1 flips z);
//     spacing pixdim[1..3], origin (qoffset_x, y, z);
//   method 1 (neither): spacing pixdim[1..3], origin 0, every axis forwards.
// Axes the transform flips get a negative spacing; a transform that is not
// axis-aligned keeps its nearest axis-aligned form and says so in
// info.dropped (NearestAxisAlignment), as does a code NIfTI-1 does not
// define (then the next method is used). `info.spacing` holds pixdim, in
// millimetres (to_mm applied), when called. InvalidArgument for a qform
// whose quaternion is not finite or longer than 1 (a = sqrt of a negative
// number: no rotation), and for a sform that is not finite.
Status NiftiPlacement(const std::string& path, const NiftiFields& f, double to_mm, VolumeInfo& info) {
  std::array<std::array<double, 3>, 3> m{};  // the matrix: sform, or the qform's rotation
  std::array<double, 3> t{};
  std::string method, notes;
  const int16_t sform = f.I16(kNiftiSformCode), qform = f.I16(kNiftiQformCode);
  const auto unknown = [&](const char* name, int16_t code) {
    if (code < 0 || code > kNiftiLastXform) {
      notes += std::string(notes.empty() ? "" : "; ") + name + " " + std::to_string(code) +
               " is not a NIfTI-1 transform code (0-4): not used";
    }
  };
  unknown("sform_code", sform);
  unknown("qform_code", qform);
  if (sform > 0 && sform <= kNiftiLastXform) {
    method = "sform";
    for (size_t r = 0; r < 3; ++r) {
      for (size_t c = 0; c < 3; ++c) m[r][c] = f.F32(kNiftiSrow + 16 * r + 4 * c);
      t[r] = f.F32(kNiftiSrow + 16 * r + 12);
    }
    for (size_t c = 0; c < 3; ++c) {
      const double length = std::hypot(m[0][c], m[1][c], m[2][c]);
      if (!std::isfinite(length) || !std::isfinite(t[c])) {
        return Status::InvalidArgument(path + ": the sform (srow_x, srow_y, srow_z) holds a number that is "
                                              "not finite");
      }
      // Method 3: the column's length is the axis's spacing.
      if (length > 0) info.spacing[c] = length * to_mm;
    }
  } else if (qform > 0 && qform <= kNiftiLastXform) {
    method = "qform";
    const double b = f.F32(kNiftiQuatern), c = f.F32(kNiftiQuatern + 4),
                 d = f.F32(kNiftiQuatern + 8);
    const double norm2 = b * b + c * c + d * d;
    // float32 rounding of a unit quaternion with a = 0 may pass 1 a little.
    constexpr double kSlack = 1e-6;
    if (!std::isfinite(norm2) || norm2 > 1 + kSlack) {
      return Status::InvalidArgument(fmt::format(
          "{}: the qform's quaternion (b, c, d) = ({}, {}, {}) is {}: NIfTI-1's method 2 needs b^2 + c^2 + "
          "d^2 <= 1 (a = sqrt(1 - that)); fix the header, or set qform_code 0",
          path, b, c, d, std::isfinite(norm2) ? "longer than 1" : "not finite"));
    }
    const double a = std::sqrt(std::max(0.0, 1 - norm2));
    const double qfac = f.F32(kNiftiPixdim) < 0 ? -1 : 1;
    m = {{{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
          {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
          {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}}};
    for (auto& row : m) row[2] *= qfac;
    for (size_t r = 0; r < 3; ++r) t[r] = f.F32(kNiftiQuatern + 12 + 4 * r);
  }
  if (!method.empty()) {
    for (size_t r = 0; r < 3; ++r) {
      if (std::isfinite(t[r])) info.origin[r] = t[r] * to_mm;
    }
    std::array<std::array<double, 3>, 3> axes{};  // the matrix's columns
    for (size_t r = 0; r < 3; ++r) {
      for (size_t c = 0; c < 3; ++c) axes[c][r] = m[r][c];
    }
    const volume_internal::AxisAlignment alignment = volume_internal::NearestAxisAlignment(axes);
    for (size_t c = 0; c < 3; ++c) info.spacing[c] *= alignment.sign[c];
    const std::string dropped = volume_internal::DescribeDroppedOrientation("the NIfTI " + method, alignment);
    notes = dropped + (!dropped.empty() && !notes.empty() ? "; " : "") + notes;
  }
  info.dropped = notes;
  return Status::OK();
}

}  // namespace

Result<VolumeInfo> OpenNifti(const std::string& path) {
  SDB_ASSIGN_OR_RETURN(const ReadOnlyFile file, ReadOnlyFile::Open(path));
  std::array<std::byte, kNiftiHeaderSize> h{};
  SDB_ASSIGN_OR_RETURN(const size_t got, file.ReadUpTo(0, h.size(), h.data()));
  if (got < h.size()) {
    return Status::InvalidArgument(path + ": has " + std::to_string(got) +
                                   " bytes, shorter than a NIfTI-1 header (348)");
  }
  // The byte order is the one in which sizeof_hdr reads 348.
  ByteOrder order = ByteOrder::kLittle;
  const int32_t size_le = NiftiFields(h, ByteOrder::kLittle).I32(0);
  const int32_t size_be = NiftiFields(h, ByteOrder::kBig).I32(0);
  if (size_le == 348) {
    order = ByteOrder::kLittle;
  } else if (size_be == 348) {
    order = ByteOrder::kBig;
  } else if (size_le == 540 || size_be == 540) {
    return Status::NotSupported(path + ": a NIfTI-2 header (sizeof_hdr 540); "
                                "SimplexDB reads NIfTI-1");
  } else {
    return Status::InvalidArgument(path + ": not a NIfTI-1 file: sizeof_hdr is " +
                                   std::to_string(size_le) +
                                   " (little-endian), expected 348");
  }
  const NiftiFields f(h, order);

  const char* magic = reinterpret_cast<const char*>(h.data() + kNiftiMagic);
  if (std::memcmp(magic, "ni1\0", 4) == 0) {
    return Status::NotSupported(path + ": magic 'ni1' marks the header of a "
                                ".hdr/.img pair; SimplexDB reads single-file .nii "
                                "(magic 'n+1')");
  }
  if (std::memcmp(magic, "n+1\0", 4) != 0) {
    std::string shown;
    for (int i = 0; i < 4; ++i) {
      const auto c = static_cast<unsigned char>(magic[i]);
      shown += (c >= 32 && c < 127) ? std::string(1, static_cast<char>(c))
                                    : "\\x" + std::to_string(c);
    }
    return Status::InvalidArgument(path + ": NIfTI-1 magic is '" + shown +
                                   "', expected 'n+1' (single-file .nii)");
  }

  // dim[0] is the number of axes; axes above 4 are accepted only as 1.
  const int16_t ndim = f.I16(kNiftiDim);
  if (ndim < 1 || ndim > 7) {
    return Status::InvalidArgument(path + ": dim[0] is " + std::to_string(ndim) +
                                   ", expected 1..7");
  }
  int dimension = ndim;
  while (dimension > 4 && f.I16(kNiftiDim + 2 * static_cast<size_t>(dimension)) == 1) {
    --dimension;
  }
  if (dimension != 3 && dimension != 4) {
    return Status::NotSupported(path + ": dim[0] is " + std::to_string(ndim) +
                                "; SimplexDB reads 3D and 4D volumes");
  }
  VolumeInfo info;
  info.dimension = dimension;
  for (int i = 0; i < dimension; ++i) {
    const int16_t n = f.I16(kNiftiDim + 2 * static_cast<size_t>(i + 1));
    if (n < 0) {
      return Status::InvalidArgument(path + ": dim[" + std::to_string(i + 1) +
                                     "] is " + std::to_string(n) +
                                     ", expected a positive size");
    }
    info.dims[static_cast<size_t>(i)] = static_cast<uint32_t>(n);
    const float pixdim = f.F32(kNiftiPixdim + 4 * static_cast<size_t>(i + 1));
    if (std::isfinite(pixdim) && pixdim != 0) {
      info.spacing[static_cast<size_t>(i)] = std::fabs(static_cast<double>(pixdim));
    }
  }

  const int16_t datatype = f.I16(kNiftiDatatype);
  const NiftiDatatype* dt = nullptr;
  for (const NiftiDatatype& t : kNiftiDatatypes) {
    if (t.code == datatype) dt = &t;
  }
  if (dt == nullptr) {
    return Status::InvalidArgument(path + ": unknown NIfTI datatype code " +
                                   std::to_string(datatype));
  }
  if (!dt->type) {
    return Status::NotSupported(path + ": NIfTI datatype " + std::to_string(datatype) +
                                " (" + std::string(dt->name) +
                                ") is not supported; supported: uint8, int8, uint16, "
                                "int16, float32, float64");
  }
  // Lengths in millimetres, times in seconds (xyzt_units).
  const auto units = static_cast<int>(static_cast<unsigned char>(h[kNiftiXyztUnits]));
  const double to_mm = NiftiSpaceToMm(units), to_s = NiftiTimeToSeconds(units);
  for (size_t i = 0; i < 3; ++i) info.spacing[i] *= to_mm;
  if (dimension == 4) {
    info.spacing[3] *= to_s;
    const float toffset = f.F32(kNiftiToffset);
    if (std::isfinite(toffset)) info.origin[3] = static_cast<double>(toffset) * to_s;
  }
  SDB_RETURN_IF_ERROR(NiftiPlacement(path, f, to_mm, info));

  info.type = *dt->type;
  const int16_t bitpix = f.I16(kNiftiBitpix);
  if (bitpix != static_cast<int16_t>(8 * VoxelSize(info.type))) {
    return Status::InvalidArgument(path + ": bitpix is " + std::to_string(bitpix) +
                                   ", expected " +
                                   std::to_string(8 * VoxelSize(info.type)) + " for " +
                                   std::string(dt->name));
  }
  const float vox_offset = f.F32(kNiftiVoxOffset);
  if (!(vox_offset >= 352.0f) || vox_offset != std::floor(vox_offset) ||
      vox_offset > 1e15f) {
    return Status::InvalidArgument(path + ": vox_offset is " +
                                   std::to_string(vox_offset) +
                                   ", expected an integer >= 352 for a .nii file");
  }
  info.order = order;
  info.encoding = Encoding::kRaw;
  info.files = {path};
  info.offset = static_cast<uint64_t>(vox_offset);
  info.description = "NIfTI-1 file " + path;
  // value = scl_slope * stored + scl_inter; slope 0 means no scaling.
  const float slope = f.F32(kNiftiSclSlope), inter = f.F32(kNiftiSclInter);
  if (std::isfinite(slope) && slope != 0) {
    info.scale = static_cast<double>(slope);
    info.shift = std::isfinite(inter) ? static_cast<double>(inter) : 0.0;
  }
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedData));
  return info;
}

}  // namespace simplexdb
