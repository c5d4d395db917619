// Synthetic scalar fields on a 3D or 4D grid, for tests, benchmarks and
// `simplexdb generate` (which writes them with WriteNrrd; nothing here does
// file I/O).
//
// Fields (value at grid point p = (x, y, z[, t]), n = dims):
//   perlin          fractal sum of `octaves` octaves of improved Perlin noise
//                   (Perlin 2002; in 4D the same construction with 4D
//                   gradients), each octave twice the frequency and half the
//                   amplitude of the last, mapped to [0, 255] like the
//                   seed's Plasma64 (65^3 Perlin noise). `frequency` is the
//                   number of lattice periods of the first octave along the
//                   longest axis; all axes use the same scale, so features
//                   are round on non-cubic grids. The seed picks the
//                   permutation table and a per-octave shift.
//   sphere          Euclidean distance from the grid centre ((n - 1) / 2 on
//                   each used axis), in grid units: 0 at the centre.
//   sines           prod over used axes of sin(2 pi frequency p_i / (n_i - 1)):
//                   `frequency` periods along each axis, in [-1, 1].
//   marschner-lobb  the Marschner-Lobb test signal (Marschner and Lobb 1994,
//                   f_M = 6, alpha = 0.25) on [-1, 1]^3, in [0, 1]. In 4D, t
//                   is a phase added to the radial cosine: 0 .. 2 pi over
//                   the time axis.
//   constant        `constant` everywhere.
//   ramp            (x + y + z [+ t]) / sum(n_i - 1): 0 at the origin corner,
//                   1 at the opposite one.
//   buckyball       a model of the electron density of C60, the molecule of
//                   the seed's Buckyball data set (sections 3.7, 4.7): a
//                   Gaussian (sigma 0.225 bond lengths) at each of the 60
//                   atoms, the vertices of a truncated icosahedron whose
//                   circumscribed sphere spans 76% of the shortest used axis
//                   around the grid centre; the sum, clamped to 1, times 255.
//                   Bonds show as ridges between atoms, the cage is hollow,
//                   the space around it 0. In 4D the cage turns about the z
//                   axis (one of its 2-fold axes) by half a turn over the
//                   time axis, so the last time step equals the first.
// `octaves` is used by perlin only; `frequency` by perlin and sines; `seed`
// by perlin only (the analytic fields do not depend on it).
//
// Determinism: the same options give the same bits on every machine. The
// PRNG is our own (SplitMix64), not <random>'s distributions, whose output
// is implementation-defined; Perlin noise uses only +, -, *, / and floor,
// which IEEE 754 rounds the same everywhere, and generate.cc is compiled
// without fused multiply-add (storage/volume/CMakeLists.txt). The analytic
// fields call sin, cos and sqrt: sqrt is exact, sin and cos may differ in the
// last bit between C libraries.
//
// Errors: only ParseFieldKind and ValidateGenerateOptions fail
// (InvalidArgument, saying what is wrong); the rest REQUIRES valid options.
//
// Thread safety: At() and Fill() are const and reentrant; one generator may
// be shared.
//
// Lifetimes: a FieldGenerator keeps its own copy of the options; options()
// lives as long as the generator. FieldKindName returns a view of static
// storage.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

enum class FieldKind {
  kPerlin,
  kSphere,
  kSineProduct,
  kMarschnerLobb,
  kConstant,
  kRamp,
  kBuckyball
};

// "perlin", "sphere", "sines", "marschner-lobb", "constant", "ramp",
// "buckyball";
// InvalidArgument listing them otherwise.
Result<FieldKind> ParseFieldKind(std::string_view name);
std::string_view FieldKindName(FieldKind kind);

struct GenerateOptions {
  FieldKind kind = FieldKind::kPerlin;
  int dimension = 3;                              // 3 or 4
  std::array<uint32_t, 4> dims = {65, 65, 65, 1};  // unused axes = 1
  uint64_t seed = 1;
  int octaves = 4;          // 1..16
  double frequency = 4.0;   // in periods across the domain, (0, 1e6]
  double constant = 0.0;    // the value of kConstant
};

// InvalidArgument naming the bad option: dimension not 3 or 4, a used axis
// with fewer than 2 samples or an unused one other than 1, octaves outside
// 1..16, a frequency outside (0, 1e6], a constant not finite.
Status ValidateGenerateOptions(const GenerateOptions& options);

// The 60 atoms of the buckyball field before scaling: the vertices of a
// truncated icosahedron of edge 2 centred on the origin.
std::array<std::array<double, 3>, 60> BuckyballAtoms();

// The value at any grid point, so callers can generate any region without
// holding the whole volume. Construction is O(1) (a 512-entry table).
class FieldGenerator {
 public:
  // REQUIRES: ValidateGenerateOptions(options).ok().
  explicit FieldGenerator(const GenerateOptions& options);

  // REQUIRES: x < dims[0], y < dims[1], z < dims[2], t < dims[3] (t == 0 in
  // 3D). Cost: O(octaves) noise evaluations (8 gradients each in 3D, 16 in
  // 4D) for perlin, 60 Gaussians for buckyball, O(1) otherwise.
  double At(uint32_t x, uint32_t y, uint32_t z, uint32_t t = 0) const;

  // out[i] = value of voxel first + i in x-fastest order, for i < count.
  // REQUIRES: first + count <= the voxel count.
  void Fill(uint64_t first, size_t count, double* out) const;

  const GenerateOptions& options() const { return options_; }

 private:
  static constexpr int kMaxOctaves = 16;

  double Perlin(uint32_t x, uint32_t y, uint32_t z, uint32_t t) const;
  double Noise3(double x, double y, double z) const;
  double Noise4(double x, double y, double z, double w) const;
  double Buckyball(uint32_t x, uint32_t y, uint32_t z, uint32_t t) const;

  GenerateOptions options_;
  double scale_ = 1;  // noise lattice units per grid step (first octave)
  // The seeded permutation of 0..255, twice, so p[p[i] + j] needs no mask.
  std::array<uint8_t, 512> perm_{};
  // A shift of each octave's lattice, in [0, 256): decorrelates octaves and
  // keeps grid points off the lattice, where gradient noise is 0.
  std::array<std::array<double, 4>, kMaxOctaves> shift_{};
  // buckyball: the 60 atoms, centred on the origin, in grid units.
  std::array<std::array<double, 3>, 60> atoms_{};
  double atom_sigma_ = 1;
};

// `v` rounded to the nearest value `type` holds, integers clamped to its
// range: how `simplexdb generate` stores a generated value.
double RepresentableValue(VoxelType type, double v);

// A volume of the field `options` describes, its voxels of `type`
// (RepresentableValue), computed for whatever range a reader asks: the
// same values as the NRRD `simplexdb generate` writes with these options,
// without the file (a parallel build's ranks each compute their own
// planes). Spacing 1, origin 0. InvalidArgument as ValidateGenerateOptions.
Result<VolumeInfo> GeneratedVolume(const GenerateOptions& options, VoxelType type);

}  // namespace simplexdb
