// Time series, OpenTimeSeries (volume.h): several 3D volumes of any format
// read as one 4D volume.
#include "storage/volume/volume.h"

#include <algorithm>
#include <limits>
#include <string_view>
#include <utility>

#include "storage/volume/volume_info_internal.h"

namespace simplexdb {

using Encoding = VolumeInfo::Encoding;
using volume_internal::SetOffsets;

Result<VolumeInfo> OpenTimeSeries(const std::vector<std::string>& paths) {
  if (paths.size() < 2) {
    return Status::InvalidArgument(
        "a time series needs at least 2 volumes, got " + std::to_string(paths.size()) +
        (paths.empty() ? std::string() : " (" + paths[0] + ")"));
  }
  if (paths.size() > std::numeric_limits<uint32_t>::max()) {
    return Status::InvalidArgument("a time series of more than 2^32 - 1 volumes");
  }
  VolumeInfo series;
  std::vector<uint64_t> offsets;
  size_t files_per_step = 0;
  for (size_t i = 0; i < paths.size(); ++i) {
    SDB_ASSIGN_OR_RETURN(VolumeInfo v, OpenVolume(paths[i]));
    const auto mismatch = [&](std::string_view what, const std::string& found,
                              const std::string& expected) {
      return Status::InvalidArgument(paths[i] + ": time step " + std::to_string(i) +
                                     " has " + std::string(what) + " " + found +
                                     ", expected " + expected + " as in " + paths[0]);
    };
    if (v.dimension != 3) {
      return mismatch("dimension", std::to_string(v.dimension), "3 (each time step 3D)");
    }
    if (i == 0) {
      files_per_step = v.files.size();
      series = v;
      series.files.clear();
      series.dimension = 4;
      series.dims[3] = static_cast<uint32_t>(paths.size());
      series.spacing[3] = 1;
    } else if (!std::equal(v.dims.begin(), v.dims.begin() + 3, series.dims.begin())) {
      return mismatch("dims", FormatDims(3, v.dims), FormatDims(3, series.dims));
    } else if (v.type != series.type) {
      return mismatch("type", std::string(VoxelTypeName(v.type)),
                      std::string(VoxelTypeName(series.type)));
    } else if (v.order != series.order && VoxelSize(v.type) > 1) {
      return mismatch("byte order", std::string(ByteOrderName(v.order)),
                      std::string(ByteOrderName(series.order)));
    } else if (v.encoding != series.encoding) {
      return mismatch("encoding", v.encoding == Encoding::kGzip ? "gzip" : "raw",
                      series.encoding == Encoding::kGzip ? "gzip" : "raw");
    } else if (v.scale != series.scale || v.shift != series.shift) {
      return mismatch("scaling", FormatScaling(v), FormatScaling(series));
    } else if (v.files.size() != files_per_step) {
      // Every data file of a volume holds as many voxels (VolumeInfo), so
      // every time step must be split into as many files as the first.
      return Status::NotSupported(paths[i] + ": stored in " +
                                  std::to_string(v.files.size()) +
                                  " data files, but " + paths[0] + " in " +
                                  std::to_string(files_per_step) +
                                  "; the time steps of a series must be split alike");
    }
    for (size_t k = 0; k < v.files.size(); ++k) {
      series.files.push_back(v.files[k]);
      offsets.push_back(v.offset_of(k));
    }
  }
  series.dims[3] = static_cast<uint32_t>(paths.size());
  SetOffsets(series, std::move(offsets));
  series.description = "time series of " + std::to_string(paths.size()) +
                       " volumes (" + paths.front() + " .. " + paths.back() + ")";
  SDB_RETURN_IF_ERROR(ValidateGrid(series.description, 4, series.dims));
  return series;
}

}  // namespace simplexdb
