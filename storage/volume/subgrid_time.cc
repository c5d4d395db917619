#include "storage/volume/subgrid_time.h"

#include <algorithm>
#include <exception>
#include <memory>
#include <string>

#include "util/out_of_memory.h"

namespace simplexdb {

Result<SubgridTimeVolume> SubgridsToTime(const VolumeInfo& in, uint32_t s, uint32_t steps) {
  if (in.dimension != 3) {
    return Status::InvalidArgument(in.description + ": a " + std::to_string(in.dimension) +
                                   "D volume; subgrids become time only for a 3D one");
  }
  if (s < 2 || s > 64) {
    return Status::InvalidArgument("subgrid side " + std::to_string(s) + ", expected 2..64");
  }
  const uint32_t cells = s * s * s;
  if (steps < 2 || steps > cells) {
    return Status::InvalidArgument("time steps " + std::to_string(steps) + ", expected 2.." +
                                   std::to_string(cells) + " (the points of a subgrid of side " +
                                   std::to_string(s) + ")");
  }
  Result<std::unique_ptr<VolumeReader>> reader = VolumeReader::Open(in);
  if (!reader.ok()) return reader.status();
  // The whole volume in memory, twice (in and out): the tool's limit.
  std::vector<double> input;
  try {
    input.resize(in.voxel_count());
  } catch (const std::exception&) {  // bad_alloc, or length_error past max_size()
    return NotEnoughMemory(in.description + " as float64 values", in.voxel_count() * 8);
  }
  constexpr uint64_t kChunk = uint64_t{1} << 20;
  for (uint64_t first = 0; first < input.size(); first += kChunk) {
    const size_t count = static_cast<size_t>(std::min<uint64_t>(kChunk, input.size() - first));
    if (Status st = (*reader)->Read(first, count, input.data() + first); !st.ok()) return st;
  }

  const auto& n = in.dims;
  SubgridTimeVolume out;
  out.dims = {SubgridAxis(n[0], s), SubgridAxis(n[1], s), SubgridAxis(n[2], s), steps};
  const uint64_t out_count = uint64_t{out.dims[0]} * out.dims[1] * out.dims[2] * steps;
  try {
    out.values.resize(out_count);
  } catch (const std::exception&) {  // bad_alloc, or length_error past max_size()
    return NotEnoughMemory("the 4D volume made from " + in.description + " as float64 values",
                           out_count * 8);
  }
  size_t o = 0;
  for (uint32_t t = 0; t < steps; ++t) {
    const uint32_t dx = t % s, dy = t / s % s, dz = t / (s * s);
    for (uint32_t k = 0; k < out.dims[2]; ++k) {
      const uint64_t z = std::min(s * k + dz, n[2] - 1);
      for (uint32_t j = 0; j < out.dims[1]; ++j) {
        const uint64_t y = std::min(s * j + dy, n[1] - 1);
        for (uint32_t i = 0; i < out.dims[0]; ++i) {
          const uint64_t x = std::min(s * i + dx, n[0] - 1);
          out.values[o++] = input[(z * n[1] + y) * n[0] + x];
        }
      }
    }
  }
  return out;
}

}  // namespace simplexdb
