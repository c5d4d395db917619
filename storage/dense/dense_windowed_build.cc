// The dense builder's one pipeline (storage/dense/dense_builder.h): its
// plan and its run (the class: dense_windowed_build_internal.h).
#include <algorithm>
#include <cstdint>
#include <string>

#include "storage/dense/dense_build_internal.h"
#include "storage/dense/dense_windowed_build_internal.h"
#include "util/process_group.h"

namespace simplexdb::dense_build {
namespace {

// Whether a grid of domain bits k with blocks of block_bits can be cut
// into several slabs: every block spanning several octaves holds scanned
// scales only (such blocks are written last, when every local table
// but the last chunk's is gone).
template <int D, class V>
bool CanCut(int k, int block_bits) {
  constexpr int S = DiamondErrors<D, V>::kLocalScales;
  return k > S + 1 && k + 1 - (block_bits + D - 1) / D >= S;
}
// The narrowest slab: a block of a local scale and four bricks of
// lattice 2 fit in one.
template <int D>
int64_t NarrowestSlab(int block_bits) {
  return std::max<int64_t>(int64_t{1} << (block_bits / D + 2), int64_t{4} << DenseDefaultBrickBits(D));
}
// The slab that holds every vertex plane.
template <int D, class V>
int64_t WholeSlab(const VolumeInfo& input, int k, int block_bits) {
  constexpr int S = DiamondErrors<D, V>::kLocalScales;
  const int64_t planes = std::min(int64_t{1} << k, int64_t{input.dims[D - 1]} - 1 + (int64_t{1} << S)) + 1;
  int64_t slab = NarrowestSlab<D>(block_bits);
  while (slab < planes) slab *= 2;
  return slab;
}

}  // namespace

template <int D, class V>
Result<DenseBuildPlan> PlanWindows(const VolumeInfo& input, const std::string& out,
                                   const DenseBuildOptions& options, int k, int threads) {
  using Build = WindowedBuild<D, V>;
  const auto at = [&](int64_t slab) { return Build(input, out, options, Clock::now(), k, threads, slab); };
  const int64_t whole = WholeSlab<D, V>(input, k, options.block_bits);
  const int64_t narrowest = NarrowestSlab<D>(options.block_bits);
  const bool can_cut = CanCut<D, V>(k, options.block_bits) && whole > narrowest;
  // The whole field when it fits; else the widest of its halves, quarters,
  // ... that fits beside what the process holds besides (code, libraries,
  // each worker's codec contexts and scratch, huge-page rounding: measured
  // 23 MiB and 2.7 MiB more per worker building 513^3, about what a
  // narrow window leaves uncounted), down to the narrowest, taken when it
  // alone fits (DenseBuildOptions::stream: the narrowest).
  const uint64_t besides = (uint64_t{20} << 20) + uint64_t(threads) * (uint64_t{4} << 20);
  const uint64_t cut_bound = options.memory_bytes > besides ? options.memory_bytes - besides : 0;
  // Ranks of a group split the slabs: at least two each where the grid
  // allows.
  const int ranks = options.group != nullptr ? options.group->size() : 1;
  const int64_t fewest = narrowest;
  int64_t slab = options.stream && can_cut ? fewest : whole;
  const int64_t vertex_planes = WholeSlab<D, V>(input, k, options.block_bits) / 2 + 1;  // at least
  while (ranks > 1 && can_cut && slab > fewest && slab * 2 * ranks > vertex_planes) slab /= 2;
  uint64_t bytes = at(slab).Bytes();
  while (can_cut && slab > fewest && (slab == whole ? bytes > options.memory_bytes : bytes > cut_bound)) {
    slab /= 2;
    bytes = at(slab).Bytes();
  }
  if (bytes > options.memory_bytes) {
    std::string need = "the field, its diamond tables, the readers and the writer need " + MiB(at(whole).Bytes());
    if (can_cut) need += "; a window of " + std::to_string(narrowest) + " planes at a time, the narrowest, " + MiB(bytes);
    return Status::ResourceExhausted(out + ": " + need + ", more than the memory bound of " +
                                     MiB(options.memory_bytes) + " (--memory-mb)");
  }
  const Build plan = at(slab);
  return DenseBuildPlan{plan.windows(), slab, plan.window_planes(), bytes};
}

template <int D, class V>
Result<DenseBuildReport> BuildWindowed(const VolumeInfo& input, const std::string& out,
                                       const DenseBuildOptions& options, Clock::time_point start, int k,
                                       int threads) {
  SDB_ASSIGN_OR_RETURN(const DenseBuildPlan plan, (PlanWindows<D, V>(input, out, options, k, threads)));
  ProcessGroup* group = options.group;
  if (group == nullptr || group->size() == 1 || plan.windows > 1) {
    return WindowedBuild<D, V>(input, out, options, start, k, threads, plan.slab_planes).Run();
  }
  // One window (a grid too small to cut): rank 0 builds alone, the
  // others wait for its outcome.
  DenseBuildOptions alone = options;
  alone.group = nullptr;
  Result<DenseBuildReport> built =
      group->rank() == 0 ? WindowedBuild<D, V>(input, out, alone, start, k, threads, plan.slab_planes).Run()
                         : Result<DenseBuildReport>(DenseBuildReport{});
  SDB_RETURN_IF_ERROR(group->Agree(built.status()));
  if (built.ok()) {
    built->ranks = group->size();
    built->slabs_built = group->rank() == 0 ? 1 : 0;
  }
  return built;
}

#define SDB_WINDOWED_(V)                                                                          \
  template Result<DenseBuildPlan> PlanWindows<3, V>(const VolumeInfo&, const std::string&,        \
                                                    const DenseBuildOptions&, int, int);         \
  template Result<DenseBuildPlan> PlanWindows<4, V>(const VolumeInfo&, const std::string&,        \
                                                    const DenseBuildOptions&, int, int);         \
  template Result<DenseBuildReport> BuildWindowed<3, V>(const VolumeInfo&, const std::string&,    \
                                                        const DenseBuildOptions&, Clock::time_point, \
                                                        int, int);                                 \
  template Result<DenseBuildReport> BuildWindowed<4, V>(const VolumeInfo&, const std::string&,    \
                                                        const DenseBuildOptions&, Clock::time_point, \
                                                        int, int);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WINDOWED_)
#undef SDB_WINDOWED_

}  // namespace simplexdb::dense_build
