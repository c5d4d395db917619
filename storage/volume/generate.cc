// Compiled with -ffp-contract=off (storage/volume/CMakeLists.txt): see "Determinism" in
// generate.h.
#include "storage/volume/generate.h"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <cmath>
#include <memory>
#include <numbers>
#include <string>

namespace simplexdb {
namespace {

// SplitMix64 (Steele, Lea and Flood 2014): a tiny, well-mixed, fully
// specified generator, the same on every platform.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits: exact in a double.
  double NextUnit() { return static_cast<double>(Next() >> 11) * 0x1p-53; }

 private:
  uint64_t state_;
};

// Perlin's quintic 6t^5 - 15t^4 + 10t^3: C2 across lattice cells.
double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }
double Lerp(double t, double a, double b) { return a + t * (b - a); }

// A lattice coordinate (an integer-valued double >= 0) mod 256. fmod is
// exact, and unlike a cast it cannot overflow.
int Wrap(double lattice) { return static_cast<int>(std::fmod(lattice, 256.0)); }

// Perlin 2002: 12 gradients, the edge midpoints of the cube (1,1,0) etc.,
// picked by the low 4 bits (4 repeated to fill 16).
double Grad3(int hash, double x, double y, double z) {
  const int h = hash & 15;
  const double u = h < 8 ? x : y;
  const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

// The 4D analogue: 32 gradients, the edge midpoints of the 4-cube (every
// permutation of (0, +-1, +-1, +-1)). Bits 3-4 pick the zero axis, bits 0-2
// the signs of the other three.
double Grad4(int hash, double x, double y, double z, double w) {
  const int h = hash & 31;
  double a, b, c;
  switch (h >> 3) {
    case 0: a = y; b = z; c = w; break;
    case 1: a = x; b = z; c = w; break;
    case 2: a = x; b = y; c = w; break;
    default: a = x; b = y; c = z; break;
  }
  return ((h & 4) == 0 ? a : -a) + ((h & 2) == 0 ? b : -b) + ((h & 1) == 0 ? c : -c);
}

// The octave sum s = sum_o 0.5^o noise_o is mapped linearly so that
// [-spread, spread] becomes [0, 255], then clamped. Measured over 4 seeds of
// 65^3 (3D) and 33^4 (4D) grids with 4 octaves: |s| has an RMS of 0.31 (3D)
// and 0.34 (4D), 99.9% of samples below 0.91 and 1.02, a maximum of 1.15
// and 1.46 (the 4D gradients are longer). With these spreads 1 or 2 samples
// in 10^4 are clamped and the values fill most of [0, 255].
constexpr double kSpread3 = 1.0;
constexpr double kSpread4 = 1.2;

// C60 (truncated icosahedron, edge 2): the cyclic permutations of
// (0, +-1, +-3 phi), (+-1, +-(2 + phi), +-2 phi) and (+-phi, +-2, +-(2 phi + 1)):
// 12 + 24 + 24 = 60 vertices on a sphere of radius sqrt(9 phi + 10).
constexpr double kPhi = std::numbers::phi;
constexpr double kBond = 2;                  // the edge length of these coordinates
const double kCageRadius = std::sqrt(9 * kPhi + 10);
constexpr double kAtomSigma = 0.225 * kBond;  // bonds show as ridges, atoms stay apart

}  // namespace

std::array<std::array<double, 3>, 60> BuckyballAtoms() {
  const double base[3][3] = {{0, 1, 3 * kPhi}, {1, 2 + kPhi, 2 * kPhi}, {kPhi, 2, 2 * kPhi + 1}};
  std::array<std::array<double, 3>, 60> atoms{};
  size_t n = 0;
  for (const auto& b : base) {
    for (int signs = 0; signs < 8; ++signs) {
      double v[3];
      for (int i = 0; i < 3; ++i) v[i] = (signs >> i & 1) != 0 ? -b[i] : b[i];
      // A zero coordinate has one sign only: skip the duplicate.
      bool duplicate = false;
      for (int i = 0; i < 3; ++i) duplicate |= b[i] == 0 && (signs >> i & 1) != 0;
      if (duplicate) continue;
      for (int r = 0; r < 3; ++r) atoms[n++] = {v[r], v[(r + 1) % 3], v[(r + 2) % 3]};
    }
  }
  assert(n == 60);
  return atoms;
}

Result<FieldKind> ParseFieldKind(std::string_view name) {
  for (FieldKind k : {FieldKind::kPerlin, FieldKind::kSphere, FieldKind::kSineProduct,
                      FieldKind::kMarschnerLobb, FieldKind::kConstant, FieldKind::kRamp,
                      FieldKind::kBuckyball}) {
    if (FieldKindName(k) == name) return k;
  }
  return Status::InvalidArgument('\'' + std::string(name) +
                                 "' is not a field; expected perlin, sphere, sines, "
                                 "marschner-lobb, constant, ramp or buckyball");
}

std::string_view FieldKindName(FieldKind kind) {
  switch (kind) {
    case FieldKind::kPerlin: return "perlin";
    case FieldKind::kSphere: return "sphere";
    case FieldKind::kSineProduct: return "sines";
    case FieldKind::kMarschnerLobb: return "marschner-lobb";
    case FieldKind::kConstant: return "constant";
    case FieldKind::kRamp: return "ramp";
    case FieldKind::kBuckyball: return "buckyball";
  }
  return "invalid";
}

Status ValidateGenerateOptions(const GenerateOptions& o) {
  if (o.dimension != 3 && o.dimension != 4) {
    return Status::InvalidArgument("generate: dimension " + std::to_string(o.dimension) +
                                   ", expected 3 or 4");
  }
  for (int i = 0; i < 4; ++i) {
    const uint32_t d = o.dims[static_cast<size_t>(i)];
    if (i < o.dimension && d < 2) {
      return Status::InvalidArgument(std::string("generate: axis ") + "xyzt"[i] +
                                     " has " + std::to_string(d) +
                                     " samples, expected at least 2");
    }
    if (i >= o.dimension && d != 1) {
      return Status::InvalidArgument(std::string("generate: unused axis ") + "xyzt"[i] +
                                     " has " + std::to_string(d) +
                                     " samples, expected 1");
    }
  }
  if (o.octaves < 1 || o.octaves > 16) {
    return Status::InvalidArgument("generate: " + std::to_string(o.octaves) +
                                   " octaves, expected 1..16");
  }
  // The bound keeps lattice coordinates (up to frequency * 2^15 + 256) far
  // inside the exact integers of a double; finer noise is aliased anyway.
  if (!(o.frequency > 0 && o.frequency <= 1e6)) {
    return Status::InvalidArgument("generate: frequency " + std::to_string(o.frequency) +
                                   ", expected a number in (0, 1e6]");
  }
  if (!std::isfinite(o.constant)) {
    return Status::InvalidArgument("generate: the constant must be finite");
  }
  return Status::OK();
}

FieldGenerator::FieldGenerator(const GenerateOptions& options) : options_(options) {
  assert(ValidateGenerateOptions(options).ok());
  uint32_t longest = 1;
  for (int i = 0; i < options_.dimension; ++i) {
    longest = std::max(longest, options_.dims[static_cast<size_t>(i)] - 1);
  }
  scale_ = options_.frequency / longest;

  // Fisher-Yates with our generator. The modulo's bias (< 2^-56) is
  // irrelevant; what matters is that it is the same everywhere.
  SplitMix64 rng(options_.seed);
  for (int i = 0; i < 256; ++i) perm_[static_cast<size_t>(i)] = static_cast<uint8_t>(i);
  for (uint64_t i = 255; i > 0; --i) {
    std::swap(perm_[i], perm_[rng.Next() % (i + 1)]);
  }
  std::copy_n(perm_.begin(), 256, perm_.begin() + 256);
  for (auto& octave : shift_) {
    for (double& s : octave) s = rng.NextUnit() * 256;
  }
  if (options_.kind == FieldKind::kBuckyball) {
    uint32_t shortest = options_.dims[0];
    for (int i = 1; i < std::min(options_.dimension, 3); ++i) {
      shortest = std::min(shortest, options_.dims[static_cast<size_t>(i)]);
    }
    const double scale = 0.38 * (shortest - 1) / kCageRadius;
    atoms_ = BuckyballAtoms();
    for (auto& atom : atoms_) {
      for (double& c : atom) c *= scale;
    }
    atom_sigma_ = kAtomSigma * scale;
  }
}

double FieldGenerator::Buckyball(uint32_t x, uint32_t y, uint32_t z, uint32_t t) const {
  const auto& n = options_.dims;
  double px = x - (n[0] - 1) / 2.0, py = y - (n[1] - 1) / 2.0;
  const double pz = z - (n[2] - 1) / 2.0;
  if (options_.dimension == 4) {
    // Turn the point the other way instead of turning 60 atoms.
    const double angle = -std::numbers::pi * t / (n[3] - 1);
    const double c = std::cos(angle), s = std::sin(angle);
    const double rx = c * px - s * py;
    py = s * px + c * py;
    px = rx;
  }
  const double inv = -0.5 / (atom_sigma_ * atom_sigma_);
  double sum = 0;
  for (const auto& a : atoms_) {
    const double dx = px - a[0], dy = py - a[1], dz = pz - a[2];
    sum += std::exp((dx * dx + dy * dy + dz * dz) * inv);
  }
  return 255 * std::min(sum, 1.0);
}

double FieldGenerator::Noise3(double x, double y, double z) const {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int X = Wrap(fx), Y = Wrap(fy), Z = Wrap(fz);
  x -= fx;
  y -= fy;
  z -= fz;
  const double u = Fade(x), v = Fade(y), w = Fade(z);
  const auto p = [&](int i) { return static_cast<int>(perm_[static_cast<size_t>(i)]); };
  const int A = p(X) + Y, AA = p(A) + Z, AB = p(A + 1) + Z;
  const int B = p(X + 1) + Y, BA = p(B) + Z, BB = p(B + 1) + Z;
  return Lerp(w,
              Lerp(v, Lerp(u, Grad3(p(AA), x, y, z), Grad3(p(BA), x - 1, y, z)),
                   Lerp(u, Grad3(p(AB), x, y - 1, z), Grad3(p(BB), x - 1, y - 1, z))),
              Lerp(v,
                   Lerp(u, Grad3(p(AA + 1), x, y, z - 1),
                        Grad3(p(BA + 1), x - 1, y, z - 1)),
                   Lerp(u, Grad3(p(AB + 1), x, y - 1, z - 1),
                        Grad3(p(BB + 1), x - 1, y - 1, z - 1))));
}

double FieldGenerator::Noise4(double x, double y, double z, double w) const {
  const double f[4] = {std::floor(x), std::floor(y), std::floor(z), std::floor(w)};
  const int X = Wrap(f[0]), Y = Wrap(f[1]), Z = Wrap(f[2]), W = Wrap(f[3]);
  const double r[4] = {x - f[0], y - f[1], z - f[2], w - f[3]};
  const double fade[4] = {Fade(r[0]), Fade(r[1]), Fade(r[2]), Fade(r[3])};
  const auto p = [&](int i) { return static_cast<int>(perm_[static_cast<size_t>(i)]); };
  // The 16 corner gradients' contributions, corner bit k set = +1 along axis
  // k, then quadrilinear interpolation along x, y, z, w in turn.
  double c[16];
  for (int k = 0; k < 16; ++k) {
    const int i = k & 1, j = (k >> 1) & 1, l = (k >> 2) & 1, m = (k >> 3) & 1;
    const int hash = p(p(p(p(X + i) + Y + j) + Z + l) + W + m);
    c[k] = Grad4(hash, r[0] - i, r[1] - j, r[2] - l, r[3] - m);
  }
  for (int axis = 0, n = 16; axis < 4; ++axis, n /= 2) {
    for (int k = 0; k < n / 2; ++k) c[k] = Lerp(fade[axis], c[2 * k], c[2 * k + 1]);
  }
  return c[0];
}

double FieldGenerator::Perlin(uint32_t x, uint32_t y, uint32_t z, uint32_t t) const {
  const bool four = options_.dimension == 4;
  double sum = 0;
  double amplitude = 1;
  double frequency = scale_;  // doubling is exact
  for (int o = 0; o < options_.octaves; ++o) {
    const auto& s = shift_[static_cast<size_t>(o)];
    const double px = x * frequency + s[0];
    const double py = y * frequency + s[1];
    const double pz = z * frequency + s[2];
    sum += amplitude * (four ? Noise4(px, py, pz, t * frequency + s[3])
                             : Noise3(px, py, pz));
    amplitude *= 0.5;
    frequency *= 2;
  }
  const double v = 127.5 + 127.5 * (sum / (four ? kSpread4 : kSpread3));
  return std::clamp(v, 0.0, 255.0);
}

double FieldGenerator::At(uint32_t x, uint32_t y, uint32_t z, uint32_t t) const {
  const auto& n = options_.dims;
  assert(x < n[0] && y < n[1] && z < n[2] && t < n[3]);
  const int dim = options_.dimension;
  const uint32_t p[4] = {x, y, z, t};
  switch (options_.kind) {
    case FieldKind::kPerlin:
      return Perlin(x, y, z, t);
    case FieldKind::kSphere: {
      double sum = 0;
      for (int i = 0; i < dim; ++i) {
        const double d = p[i] - (n[static_cast<size_t>(i)] - 1) / 2.0;
        sum += d * d;
      }
      return std::sqrt(sum);
    }
    case FieldKind::kSineProduct: {
      double product = 1;
      for (int i = 0; i < dim; ++i) {
        product *= std::sin(2 * std::numbers::pi * options_.frequency * p[i] /
                            (n[static_cast<size_t>(i)] - 1));
      }
      return product;
    }
    case FieldKind::kMarschnerLobb: {
      // Marschner and Lobb 1994, eq. 2, on [-1, 1]^3.
      constexpr double kFm = 6, kAlpha = 0.25, kPi = std::numbers::pi;
      const auto unit = [&](int i) {
        return 2.0 * p[i] / (n[static_cast<size_t>(i)] - 1) - 1;
      };
      const double ux = unit(0), uy = unit(1), uz = unit(2);
      const double phase = dim == 4 ? 2 * kPi * t / (n[3] - 1) : 0;
      const double r = std::sqrt(ux * ux + uy * uy);
      const double rho_r = std::cos(2 * kPi * kFm * std::cos(kPi * r / 2) + phase);
      return (1 - std::sin(kPi * uz / 2) + kAlpha * (1 + rho_r)) / (2 * (1 + kAlpha));
    }
    case FieldKind::kConstant:
      return options_.constant;
    case FieldKind::kBuckyball:
      return Buckyball(x, y, z, t);
    case FieldKind::kRamp: {
      double sum = 0, extent = 0;
      for (int i = 0; i < dim; ++i) {
        sum += p[i];
        extent += n[static_cast<size_t>(i)] - 1;
      }
      return sum / extent;
    }
  }
  assert(false && "invalid FieldKind");
  return 0;
}

void FieldGenerator::Fill(uint64_t first, size_t count, double* out) const {
  const auto& n = options_.dims;
  assert(first + count <= uint64_t{n[0]} * n[1] * n[2] * n[3]);
  uint64_t rest = first;
  uint32_t x = static_cast<uint32_t>(rest % n[0]);
  rest /= n[0];
  uint32_t y = static_cast<uint32_t>(rest % n[1]);
  rest /= n[1];
  uint32_t z = static_cast<uint32_t>(rest % n[2]);
  uint32_t t = static_cast<uint32_t>(rest / n[2]);
  for (size_t i = 0; i < count; ++i) {
    out[i] = At(x, y, z, t);
    if (++x < n[0]) continue;
    x = 0;
    if (++y < n[1]) continue;
    y = 0;
    if (++z < n[2]) continue;
    z = 0;
    ++t;
  }
}

double RepresentableValue(VoxelType type, double v) {
  const auto clamp_round = [&](double lo, double hi) { return std::clamp(std::nearbyint(v), lo, hi); };
  switch (type) {
    case VoxelType::kU8: return clamp_round(0, 255);
    case VoxelType::kI8: return clamp_round(-128, 127);
    case VoxelType::kU16: return clamp_round(0, 65535);
    case VoxelType::kI16: return clamp_round(-32768, 32767);
    case VoxelType::kF32: return static_cast<double>(static_cast<float>(v));
    case VoxelType::kF64: return v;
  }
  return v;
}

namespace {

std::string Shortest(double v) {  // the shortest text that reads back as v
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

}  // namespace

Result<VolumeInfo> GeneratedVolume(const GenerateOptions& options, VoxelType type) {
  SDB_RETURN_IF_ERROR(ValidateGenerateOptions(options));
  if (!IsValidVoxelType(type)) {
    return Status::NotSupported("voxel type code " + std::to_string(static_cast<int>(type)));
  }
  VolumeInfo info;
  info.dimension = options.dimension;
  info.dims = options.dims;
  info.type = type;
  info.order = ByteOrder::kLittle;
  info.encoding = VolumeInfo::Encoding::kGenerated;
  info.generator = std::make_shared<const FieldGenerator>(options);
  // What a store records as its source: the options the field uses.
  info.description = "generated " + std::string(FieldKindName(options.kind)) + " field";
  if (options.kind == FieldKind::kPerlin) {
    info.description += " (seed " + std::to_string(options.seed) + ", " + std::to_string(options.octaves) +
                        " octaves, frequency " + Shortest(options.frequency) + ")";
  } else if (options.kind == FieldKind::kSineProduct) {
    info.description += " (frequency " + Shortest(options.frequency) + ")";
  } else if (options.kind == FieldKind::kConstant) {
    info.description += " (" + Shortest(options.constant) + ")";
  }
  return info;
}

}  // namespace simplexdb
