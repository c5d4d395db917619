#include "storage/volume/volume.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>
#include <string_view>
#include <system_error>
#include <utility>

namespace simplexdb {
namespace {

using Encoding = VolumeInfo::Encoding;

// ---------------------------------------------------------------------------
// Text helpers.

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

std::string Lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return r;
}

std::vector<std::string_view> SplitWhitespace(std::string_view s) {
  std::vector<std::string_view> parts;
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    const size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t') ++i;
    if (i > start) parts.push_back(s.substr(start, i - start));
  }
  return parts;
}

template <class Int>
std::optional<Int> ParseInt(std::string_view s) {
  Int v{};
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

std::optional<double> ParseDouble(std::string_view s) {
  double v = 0;
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

// The same failure (same code) with another message.
Status WithMessage(const Status& s, const std::string& msg) {
  switch (s.code()) {
    case Status::Code::kOk: return Status::OK();
    case Status::Code::kInvalidArgument: return Status::InvalidArgument(msg);
    case Status::Code::kNotFound: return Status::NotFound(msg);
    case Status::Code::kCorruption: return Status::Corruption(msg);
    case Status::Code::kIOError: return Status::IOError(msg);
    case Status::Code::kNotSupported: return Status::NotSupported(msg);
    case Status::Code::kResourceExhausted: return Status::ResourceExhausted(msg);
  }
  return Status::IOError(msg);
}

// The same failure with `prefix` ("file.nrrd: ") in front of its message.
Status Prefixed(const Status& s, const std::string& prefix) {
  return WithMessage(s, prefix + std::string(s.message()));
}

// ---------------------------------------------------------------------------
// Files. errno is translated into a Status here, once.

Status ErrnoStatus(const std::string& path, std::string_view what, int err) {
  const std::string msg = path + ": " + std::string(what) + ": " +
                          std::error_code(err, std::generic_category()).message();
  if (err == ENOENT || err == ENOTDIR) return Status::NotFound(msg);
  return Status::IOError(msg);
}

// An open file descriptor, closed on destruction.
class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(Fd&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) {
      Reset();
      fd_ = std::exchange(o.fd_, -1);
    }
    return *this;
  }
  ~Fd() { Reset(); }
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }
  void Reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

Result<Fd> OpenForReading(const std::string& path) {
  int fd;
  do {
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return ErrnoStatus(path, "cannot open", errno);
  Fd f(fd);
  struct stat st;
  if (::fstat(fd, &st) != 0) return ErrnoStatus(path, "cannot stat", errno);
  if (S_ISDIR(st.st_mode)) {
    return Status::InvalidArgument(path + ": is a directory, not a volume file");
  }
  return f;
}

Result<uint64_t> FileSize(const std::string& path, int fd) {
  struct stat st;
  if (::fstat(fd, &st) != 0) return ErrnoStatus(path, "cannot stat", errno);
  return static_cast<uint64_t>(st.st_size);
}

// Reads up to n bytes at `pos`; fewer only at the end of the file.
Result<size_t> PreadUpTo(const std::string& path, int fd, uint64_t pos,
                         size_t n, std::byte* out) {
  size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd, out + done, n - done,
                              static_cast<off_t>(pos + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return ErrnoStatus(path, "read failed at byte " + std::to_string(pos + done),
                         errno);
    }
    if (r == 0) break;
    done += static_cast<size_t>(r);
  }
  return done;
}

// The byte position just after the first `lines` newlines at or after
// `start`. Corruption if the file has fewer lines.
Result<uint64_t> SkipLines(const std::string& path, uint64_t start,
                           int64_t lines) {
  if (lines == 0) return start;
  SDB_ASSIGN_OR_RETURN(Fd fd, OpenForReading(path));
  std::vector<std::byte> buf(64 * 1024);
  uint64_t pos = start;
  int64_t seen = 0;
  while (true) {
    SDB_ASSIGN_OR_RETURN(const size_t got,
                         PreadUpTo(path, fd.get(), pos, buf.size(), buf.data()));
    if (got == 0) {
      return Status::Corruption(path + ": 'line skip: " + std::to_string(lines) +
                                "' but the file has only " + std::to_string(seen) +
                                " lines");
    }
    for (size_t i = 0; i < got; ++i) {
      if (buf[i] == std::byte{'\n'} && ++seen == lines) return pos + i + 1;
    }
    pos += got;
  }
}

// ---------------------------------------------------------------------------
// Grid and data checks shared by every format.

// A 4D grid with one time step is read as 3D (see volume.h).
void DropSingleTimeStep(VolumeInfo& info) {
  if (info.dimension == 4 && info.dims[3] == 1) {
    info.dimension = 3;
    info.spacing[3] = 1;
  }
}

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

// Checks that every data file exists, is readable and is long enough.
// `truncated` builds the status for a file too short (its code differs: the
// caller's dims for raw input, a corrupt file for a header format).
Status CheckDataFiles(const VolumeInfo& info,
                      Status (*truncated)(std::string_view)) {
  const uint64_t bytes_per_file = info.voxels_per_file() * VoxelSize(info.type);
  for (size_t i = 0; i < info.files.size(); ++i) {
    const std::string& path = info.files[i];
    const uint64_t offset = info.offset_of(i);
    Result<Fd> opened = OpenForReading(path);
    if (!opened.ok()) {
      return WithMessage(opened.status(), std::string(opened.status().message()) +
                                              DataFileContext(info, path));
    }
    const Fd fd = std::move(opened).value();
    SDB_ASSIGN_OR_RETURN(const uint64_t size, FileSize(path, fd.get()));
    if (info.encoding == Encoding::kRaw) {
      // Bytes after the voxels are trailing data we ignore (see volume.h).
      if (size < offset || size - offset < bytes_per_file) {
        const std::string what =
            info.files.size() == 1
                ? FormatDims(info.dimension, info.dims)
                : std::to_string(info.voxels_per_file()) + " voxels (one of " +
                      std::to_string(info.files.size()) + " files of " +
                      FormatDims(info.dimension, info.dims) + ")";
        return truncated(
            path + ": has " + std::to_string(size) + " bytes, expected at least " +
            std::to_string(offset + bytes_per_file) + " (" + what + " " +
            std::string(VoxelTypeName(info.type)) + " = " +
            std::to_string(bytes_per_file) + " bytes after offset " +
            std::to_string(offset) + ")" + DataFileContext(info, path));
      }
      continue;
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
    std::array<std::byte, 4> b{};
    SDB_ASSIGN_OR_RETURN(size_t got, PreadUpTo(path, fd.get(), offset, 2, b.data()));
    if (got != 2 || b[0] != std::byte{0x1f} || b[1] != std::byte{0x8b}) {
      return Status::Corruption(path + ": encoding gzip, but byte " +
                                std::to_string(offset) +
                                " does not start gzip data (magic 1f 8b)" +
                                DataFileContext(info, path));
    }
    SDB_ASSIGN_OR_RETURN(got, PreadUpTo(path, fd.get(), size - 4, 4, b.data()));
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

// Keeps one offset when every file has the same, as most volumes do.
void SetOffsets(VolumeInfo& info, std::vector<uint64_t> offsets) {
  const bool same = std::all_of(offsets.begin(), offsets.end(),
                                [&](uint64_t o) { return o == offsets.front(); });
  info.offset = offsets.empty() ? 0 : offsets.front();
  info.file_offsets.clear();
  if (!same) info.file_offsets = std::move(offsets);
}

// ---------------------------------------------------------------------------
// NRRD.

// The header's lines (without line ends), and where attached data starts.
struct NrrdHeaderText {
  std::vector<std::string> lines;
  bool ended_by_blank_line = false;
  uint64_t data_start = 0;  // after the blank line, when there is one
};

// Headers are short; the cap stops a wrong file from being read whole.
constexpr size_t kMaxNrrdHeader = 16 << 20;

Result<NrrdHeaderText> ReadNrrdHeader(const std::string& path) {
  SDB_ASSIGN_OR_RETURN(Fd fd, OpenForReading(path));
  NrrdHeaderText h;
  std::string pending;  // a line not yet ended
  uint64_t pos = 0;
  std::vector<std::byte> buf(64 * 1024);
  while (true) {
    SDB_ASSIGN_OR_RETURN(const size_t got,
                         PreadUpTo(path, fd.get(), pos, buf.size(), buf.data()));
    for (size_t i = 0; i < got; ++i) {
      const char c = static_cast<char>(buf[i]);
      if (c != '\n') {
        pending.push_back(c);
        continue;
      }
      if (!pending.empty() && pending.back() == '\r') pending.pop_back();
      if (h.lines.empty() && pending.rfind("NRRD", 0) != 0) {
        return Status::InvalidArgument(
            path + ": not a NRRD file: the first line is '" + pending.substr(0, 40) +
            "', expected the magic NRRD0001 .. NRRD0005");
      }
      if (pending.empty()) {
        h.ended_by_blank_line = true;
        h.data_start = pos + i + 1;
        return h;
      }
      h.lines.push_back(std::move(pending));
      pending.clear();
    }
    pos += got;
    if (got == 0) break;
    if (pos > kMaxNrrdHeader) {
      return Status::InvalidArgument(path + ": no end of the NRRD header in its first " +
                                     std::to_string(kMaxNrrdHeader) + " bytes");
    }
    if (h.lines.empty() && pending.size() >= 4 && pending.rfind("NRRD", 0) != 0) {
      return Status::InvalidArgument(path +
                                     ": not a NRRD file: it does not start with the "
                                     "magic NRRD0001 .. NRRD0005");
    }
  }
  if (!pending.empty()) {
    if (pending.back() == '\r') pending.pop_back();
    h.lines.push_back(std::move(pending));
  }
  if (h.lines.empty()) return Status::InvalidArgument(path + ": empty file, not NRRD");
  return h;
}

// Expands a "data file:" format such as "slice%03d.raw": one %d (or %i, %u)
// with an optional 0 flag and width. Parsed here rather than handed to
// printf: the format comes from a file.
Result<std::string> ExpandNrrdFormat(std::string_view format, int64_t value) {
  const size_t pct = format.find('%');
  size_t i = pct + 1;
  bool zero = false;
  if (i < format.size() && format[i] == '0') {
    zero = true;
    ++i;
  }
  size_t width = 0;
  while (i < format.size() && format[i] >= '0' && format[i] <= '9' && width < 100) {
    width = width * 10 + static_cast<size_t>(format[i] - '0');
    ++i;
  }
  if (i >= format.size() || (format[i] != 'd' && format[i] != 'i' && format[i] != 'u') ||
      format.find('%', i) != std::string_view::npos) {
    return Status::NotSupported("data file format '" + std::string(format) +
                                "': only one %d conversion (with optional 0 flag "
                                "and width) is supported");
  }
  // printf semantics: the 0 flag pads after the sign, spaces before it.
  std::string digits = std::to_string(value < 0 ? -value : value);
  if (zero) {
    while (digits.size() + (value < 0 ? 1 : 0) < width) digits.insert(0, "0");
    if (value < 0) digits.insert(0, "-");
  } else {
    if (value < 0) digits.insert(0, "-");
    while (digits.size() < width) digits.insert(0, " ");
  }
  return std::string(format.substr(0, pct)) + digits + std::string(format.substr(i + 1));
}

// Axis kinds of a scalar field's sample grid (NRRD section 6, "kinds").
bool IsDomainKind(std::string_view kind) {
  const std::string k = Lower(kind);
  return k == "domain" || k == "space" || k == "time" || k == "list" ||
         k == "none" || k == "???";
}

// Parses "(a,b,c) (d,e,f) none ..." into the vector lengths (NaN for none).
std::optional<std::vector<double>> ParseSpaceDirections(std::string_view s) {
  std::vector<double> lengths;
  size_t i = 0;
  while (true) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    if (i >= s.size()) break;
    if (s.substr(i, 4) == "none") {
      lengths.push_back(std::numeric_limits<double>::quiet_NaN());
      i += 4;
      continue;
    }
    if (s[i] != '(') return std::nullopt;
    const size_t close = s.find(')', i);
    if (close == std::string_view::npos) return std::nullopt;
    std::string_view inner = s.substr(i + 1, close - i - 1);
    double sum = 0;
    while (true) {
      const size_t comma = inner.find(',');
      const auto v = ParseDouble(Trim(inner.substr(0, comma)));
      if (!v) return std::nullopt;
      sum += *v * *v;
      if (comma == std::string_view::npos) break;
      inner.remove_prefix(comma + 1);
    }
    lengths.push_back(std::sqrt(sum));
    i = close + 1;
  }
  return lengths;
}

}  // namespace

// ---------------------------------------------------------------------------
// VolumeInfo.

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

// ---------------------------------------------------------------------------
// Raw.

Result<VolumeInfo> OpenRawVolume(const std::string& path, int dimension,
                                 std::array<uint32_t, 4> dims, VoxelType type,
                                 ByteOrder order, uint64_t offset) {
  if (!IsValidVoxelType(type)) {
    return Status::NotSupported(path + ": voxel type code " +
                                std::to_string(static_cast<int>(type)) +
                                " is not one of the six supported types");
  }
  VolumeInfo info;
  info.dimension = dimension;
  info.dims = dims;
  info.type = type;
  info.order = order;
  info.encoding = Encoding::kRaw;
  info.files = {path};
  info.offset = offset;
  info.description = "raw file " + path;
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedRaw));
  return info;
}

// ---------------------------------------------------------------------------
// NRRD.

namespace {

// The fields of a NRRD header that say where the voxels are and what they
// are, as written (checked for consistency by NrrdGrid and NrrdData).
struct NrrdFields {
  std::optional<int> dimension;
  std::optional<VoxelType> type;
  std::vector<uint64_t> sizes;
  std::optional<Encoding> encoding;
  std::optional<ByteOrder> endian;
  std::optional<std::string> data_file;  // the value of "data file:"
  std::vector<std::string> list_files;   // the lines after "data file: LIST"
  int64_t line_skip = 0;
  int64_t byte_skip = 0;  // -1: the data are the last bytes of the file
  std::vector<std::string> kinds;
  std::vector<double> spacings;
  std::vector<double> direction_lengths;  // of "space directions:", NaN = none
};

// Parses the magic and every field line. Unknown fields are ignored.
Result<NrrdFields> ParseNrrdFields(const std::string& path, const NrrdHeaderText& header) {
  const std::string& magic = header.lines[0];
  if (magic.size() != 8 || magic.rfind("NRRD000", 0) != 0 || magic[7] < '1' ||
      magic[7] > '5') {
    if (magic.size() == 8 && magic.rfind("NRRD", 0) == 0) {
      return Status::NotSupported(path + ": NRRD magic '" + magic +
                                  "' is not a version this reader knows "
                                  "(NRRD0001 .. NRRD0005)");
    }
    return Status::InvalidArgument(path + ": first line '" + magic.substr(0, 40) +
                                   "' is not a NRRD magic (NRRD0001 .. NRRD0005)");
  }
  NrrdFields f;
  bool list_mode = false;  // after "data file: LIST" every line is a file name
  std::set<std::string> seen;
  for (size_t n = 1; n < header.lines.size(); ++n) {
    const std::string& line = header.lines[n];
    const auto bad = [&](const std::string& why) {
      return Status::InvalidArgument(path + ": header line " + std::to_string(n + 1) +
                                     " '" + line.substr(0, 80) + "': " + why);
    };
    if (list_mode) {
      const std::string_view name = Trim(line);
      if (!name.empty()) f.list_files.emplace_back(name);
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) return bad("expected 'field: value'");
    if (colon + 1 < line.size() && line[colon + 1] == '=') continue;  // key:=value
    const std::string field = Lower(Trim(std::string_view(line).substr(0, colon)));
    const std::string_view value = Trim(std::string_view(line).substr(colon + 1));
    // Both spellings of the multi-word fields are in the specification.
    const std::string name = field == "datafile"   ? "data file"
                             : field == "lineskip" ? "line skip"
                             : field == "byteskip" ? "byte skip"
                                                   : field;
    if (!seen.insert(name).second) return bad("field '" + name + "' appears twice");

    if (name == "dimension") {
      const auto d = ParseInt<int>(value);
      if (!d || *d < 1) return bad("expected a positive integer");
      f.dimension = *d;
    } else if (name == "type") {
      auto t = ParseVoxelType(value);
      if (!t.ok()) return Prefixed(t.status(), path + ": ");
      f.type = *t;
    } else if (name == "sizes") {
      for (std::string_view part : SplitWhitespace(value)) {
        const auto size = ParseInt<uint64_t>(part);
        if (!size) return bad("'" + std::string(part) + "' is not a size");
        if (*size > std::numeric_limits<uint32_t>::max()) {
          return bad("size " + std::string(part) + " exceeds 2^32 - 1");
        }
        f.sizes.push_back(*size);
      }
    } else if (name == "encoding") {
      const std::string e = Lower(value);
      if (e == "raw") {
        f.encoding = Encoding::kRaw;
      } else if (e == "gzip" || e == "gz") {
        f.encoding = Encoding::kGzip;
      } else if (e == "txt" || e == "text" || e == "ascii" || e == "hex" ||
                 e == "bzip2" || e == "bz2" || e == "zrl") {
        return Status::NotSupported(path + ": NRRD encoding '" + std::string(value) +
                                    "' is not supported; supported: raw, gzip");
      } else {
        return bad("unknown encoding '" + std::string(value) +
                   "'; expected raw or gzip (or txt, hex, bzip2)");
      }
    } else if (name == "endian") {
      const std::string e = Lower(value);
      if (e != "little" && e != "big") return bad("expected 'little' or 'big'");
      f.endian = e == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
    } else if (name == "data file") {
      f.data_file = std::string(value);
      const auto parts = SplitWhitespace(value);
      list_mode = !parts.empty() && parts[0] == "LIST";
    } else if (name == "line skip") {
      const auto skip = ParseInt<int64_t>(value);
      if (!skip || *skip < 0) return bad("expected a non-negative integer");
      f.line_skip = *skip;
    } else if (name == "byte skip") {
      const auto skip = ParseInt<int64_t>(value);
      if (!skip || *skip < -1) return bad("expected -1 or a non-negative integer");
      f.byte_skip = *skip;
    } else if (name == "kinds") {
      for (std::string_view k : SplitWhitespace(value)) f.kinds.emplace_back(k);
    } else if (name == "spacings") {
      for (std::string_view part : SplitWhitespace(value)) {
        const auto spacing = ParseDouble(part);
        if (!spacing) return bad("'" + std::string(part) + "' is not a spacing");
        f.spacings.push_back(*spacing);
      }
    } else if (name == "space directions") {
      auto lengths = ParseSpaceDirections(value);
      if (!lengths) return bad("expected vectors like (1,0,0) or 'none'");
      f.direction_lengths = std::move(*lengths);
    }
    // Every other field (content, space, space origin, centers, units,
    // labels, axis mins, min, max, ...) says nothing about where the voxels
    // are or what they mean numerically: ignored.
  }
  return f;
}

// The grid, type, byte order, encoding and spacing the fields describe.
Result<VolumeInfo> NrrdGrid(const std::string& path, const NrrdFields& f) {
  const auto missing = [&](std::string_view field) {
    return Status::InvalidArgument(path + ": NRRD header has no '" +
                                   std::string(field) + ":' field");
  };
  if (!f.dimension) return missing("dimension");
  if (!f.type) return missing("type");
  if (f.sizes.empty()) return missing("sizes");
  if (!f.encoding) return missing("encoding");
  if (!f.endian && VoxelSize(*f.type) > 1) return missing("endian");
  if (*f.dimension != 3 && *f.dimension != 4) {
    return Status::NotSupported(path + ": dimension " + std::to_string(*f.dimension) +
                                "; SimplexDB reads 3D and 4D volumes");
  }
  const auto d = static_cast<size_t>(*f.dimension);
  const auto count_mismatch = [&](std::string_view field, size_t count) {
    return Status::InvalidArgument(path + ": '" + std::string(field) + ":' has " +
                                   std::to_string(count) + " values, expected " +
                                   std::to_string(d) + " (the dimension)");
  };
  if (f.sizes.size() != d) return count_mismatch("sizes", f.sizes.size());
  if (!f.kinds.empty()) {
    if (f.kinds.size() != d) return count_mismatch("kinds", f.kinds.size());
    for (size_t i = 0; i < d; ++i) {
      if (!IsDomainKind(f.kinds[i])) {
        return Status::NotSupported(path + ": axis " + std::to_string(i) +
                                    " has kind '" + f.kinds[i] +
                                    "'; SimplexDB reads scalar fields on a grid "
                                    "(kinds domain, space, time, list)");
      }
    }
  }
  // "spacings:" wins over "space directions:" (the specification allows
  // only one of them).
  const bool from_spacings = !f.spacings.empty();
  const std::vector<double>& spacing = from_spacings ? f.spacings : f.direction_lengths;
  if (!spacing.empty() && spacing.size() != d) {
    return count_mismatch(from_spacings ? "spacings" : "space directions", spacing.size());
  }

  VolumeInfo info;
  info.dimension = *f.dimension;
  for (size_t i = 0; i < d; ++i) {
    info.dims[i] = static_cast<uint32_t>(f.sizes[i]);
    if (!spacing.empty() && std::isfinite(spacing[i]) && spacing[i] > 0) {
      info.spacing[i] = spacing[i];  // NaN, "none": 1
    }
  }
  info.type = *f.type;
  info.order = f.endian.value_or(ByteOrder::kLittle);
  info.encoding = *f.encoding;
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  return info;
}

// Fills info.files, offsets and description: the attached data, or the
// "data file:" (one name, LIST or format), after line and byte skips.
Status NrrdData(const std::string& path, const NrrdHeaderText& header,
                const NrrdFields& f, VolumeInfo& info) {
  const size_t d = f.sizes.size();
  const std::filesystem::path header_dir = std::filesystem::path(path).parent_path();
  const auto resolve = [&](std::string_view name) {
    const std::filesystem::path p(name);
    return (p.is_absolute() || header_dir.empty() ? p : header_dir / p).string();
  };
  size_t subdim = d;  // the dimensions each data file holds
  uint64_t base = 0;  // where each data file's content starts
  if (!f.data_file) {
    if (!header.ended_by_blank_line) {
      return Status::InvalidArgument(path +
                                     ": the NRRD header has no 'data file:' field "
                                     "and no blank line before attached data");
    }
    info.files = {path};
    base = header.data_start;
    info.description = "NRRD file " + path;
  } else {
    const auto parts = SplitWhitespace(*f.data_file);
    std::optional<size_t> given_subdim;
    const auto parse_subdim = [&](std::string_view text) -> Status {
      const auto s = ParseInt<size_t>(text);
      if (!s || *s < 1 || *s > d) {
        return Status::InvalidArgument(path + ": data file subdimension '" +
                                       std::string(text) + "', expected 1.." +
                                       std::to_string(d));
      }
      given_subdim = *s;
      return Status::OK();
    };
    if (!parts.empty() && parts[0] == "LIST") {
      if (parts.size() > 2) {
        return Status::InvalidArgument(path + ": expected 'data file: LIST [subdim]'");
      }
      if (parts.size() == 2) SDB_RETURN_IF_ERROR(parse_subdim(parts[1]));
      for (const std::string& name : f.list_files) info.files.push_back(resolve(name));
      subdim = given_subdim.value_or(d - 1);
    } else if ((parts.size() == 4 || parts.size() == 5) &&
               parts[0].find('%') != std::string_view::npos) {
      // "<format> <min> <max> <step> [<subdim>]", bounded to int32 so the
      // arithmetic below cannot overflow.
      const auto lo = ParseInt<int32_t>(parts[1]);
      const auto hi = ParseInt<int32_t>(parts[2]);
      const auto step = ParseInt<int32_t>(parts[3]);
      if (!lo || !hi || !step || *step == 0 ||
          (int64_t{*hi} - *lo) / *step < 0 || (int64_t{*hi} - *lo) / *step > (1 << 24)) {
        return Status::InvalidArgument(path + ": data file '" + *f.data_file +
                                       "': expected '<format> <min> <max> <step> "
                                       "[<subdim>]' with a non-zero step from min "
                                       "towards max");
      }
      if (parts.size() == 5) SDB_RETURN_IF_ERROR(parse_subdim(parts[4]));
      for (int64_t v = *lo; *step > 0 ? v <= *hi : v >= *hi; v += *step) {
        auto name = ExpandNrrdFormat(parts[0], v);
        if (!name.ok()) return Prefixed(name.status(), path + ": ");
        info.files.push_back(resolve(*name));
      }
      subdim = given_subdim.value_or(d - 1);
    } else {
      info.files = {resolve(*f.data_file)};
    }
    info.description = "NRRD header " + path;
  }
  uint64_t files_needed = 1;
  for (size_t i = subdim; i < d; ++i) files_needed *= f.sizes[i];
  if (info.files.size() != files_needed) {
    return Status::InvalidArgument(
        path + ": " + std::to_string(info.files.size()) + " data files, expected " +
        std::to_string(files_needed) + " (one per " + std::to_string(subdim) +
        "D slab of " + FormatDims(info.dimension, info.dims) + ")");
  }
  if (f.byte_skip != 0 && info.encoding == Encoding::kGzip) {
    return Status::NotSupported(path + ": 'byte skip: " + std::to_string(f.byte_skip) +
                                "' with gzip encoding (a skip inside the "
                                "decompressed stream) is not supported");
  }
  const uint64_t bytes_per_file = info.voxels_per_file() * VoxelSize(info.type);
  std::vector<uint64_t> offsets;
  for (const std::string& file : info.files) {
    SDB_ASSIGN_OR_RETURN(uint64_t start, SkipLines(file, base, f.line_skip));
    if (f.byte_skip == -1) {  // raw only (checked above)
      SDB_ASSIGN_OR_RETURN(Fd fd, OpenForReading(file));
      SDB_ASSIGN_OR_RETURN(const uint64_t size, FileSize(file, fd.get()));
      if (size < start || size - start < bytes_per_file) {
        return Status::Corruption(file + ": has " + std::to_string(size) +
                                  " bytes, expected at least " +
                                  std::to_string(start + bytes_per_file) +
                                  " ('byte skip: -1': the data end the file)");
      }
      start = size - bytes_per_file;
    } else {
      start += static_cast<uint64_t>(f.byte_skip);
    }
    offsets.push_back(start);
  }
  SetOffsets(info, std::move(offsets));
  return Status::OK();
}

}  // namespace

Result<VolumeInfo> OpenNrrd(const std::string& path) {
  SDB_ASSIGN_OR_RETURN(const NrrdHeaderText header, ReadNrrdHeader(path));
  SDB_ASSIGN_OR_RETURN(const NrrdFields fields, ParseNrrdFields(path, header));
  SDB_ASSIGN_OR_RETURN(VolumeInfo info, NrrdGrid(path, fields));
  SDB_RETURN_IF_ERROR(NrrdData(path, header, fields, info));
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedData));
  return info;
}

// ---------------------------------------------------------------------------
// NIfTI-1.

namespace {

// Field offsets in the 348-byte NIfTI-1 header (nifti1.h).
constexpr size_t kNiftiHeaderSize = 348;
constexpr size_t kNiftiDim = 40;        // int16 dim[8]
constexpr size_t kNiftiDatatype = 70;   // int16
constexpr size_t kNiftiBitpix = 72;     // int16
constexpr size_t kNiftiPixdim = 76;     // float32 pixdim[8]
constexpr size_t kNiftiVoxOffset = 108; // float32
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

}  // namespace

Result<VolumeInfo> OpenNifti(const std::string& path) {
  SDB_ASSIGN_OR_RETURN(Fd fd, OpenForReading(path));
  std::array<std::byte, kNiftiHeaderSize> h{};
  SDB_ASSIGN_OR_RETURN(const size_t got,
                       PreadUpTo(path, fd.get(), 0, h.size(), h.data()));
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
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedData));
  return info;
}

// ---------------------------------------------------------------------------
// Time series and dispatch.

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

Result<VolumeInfo> OpenVolume(const std::string& path) {
  const std::string lower = Lower(path);
  const auto ends_with = [&](std::string_view suffix) {
    return lower.size() >= suffix.size() &&
           lower.compare(lower.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  if (ends_with(".nrrd") || ends_with(".nhdr")) return OpenNrrd(path);
  if (ends_with(".nii")) return OpenNifti(path);
  if (ends_with(".nii.gz")) {
    return Status::NotSupported(path + ": gzip-compressed NIfTI is not read; "
                                "gunzip it to a .nii first");
  }
  if (ends_with(".hdr") || ends_with(".img")) {
    return Status::NotSupported(path + ": NIfTI-1/Analyze .hdr/.img pairs are not "
                                "read; convert to a single-file .nii");
  }
  return Status::InvalidArgument(path + ": not a .nrrd, .nhdr or .nii file; raw "
                                 "input needs --dims and --type (and --endian, "
                                 "--offset if not little-endian at byte 0)");
}

// ---------------------------------------------------------------------------
// Reading voxels.

namespace volume_internal {

// The voxel bytes of one data file, addressed from its first voxel.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Reads exactly n bytes at `pos`; Corruption on a short read.
  virtual Status ReadAt(uint64_t pos, size_t n, std::byte* out) = 0;
};

namespace {

// A raw data file, read with pread through a read-ahead buffer.
class RawSource final : public ByteSource {
 public:
  RawSource(std::string path, Fd fd, uint64_t offset)
      : path_(std::move(path)), fd_(std::move(fd)), offset_(offset) {}

  Status ReadAt(uint64_t pos, size_t n, std::byte* out) override {
    const uint64_t at = offset_ + pos;
    if (at >= cache_pos_ && at + n <= cache_pos_ + cache_len_) {
      std::memcpy(out, cache_.data() + (at - cache_pos_), n);
      return Status::OK();
    }
    if (n >= kReadAhead) {  // large reads go straight to the caller
      SDB_ASSIGN_OR_RETURN(const size_t got, PreadUpTo(path_, fd_.get(), at, n, out));
      return got == n ? Status::OK() : Short(at, n, got);
    }
    cache_.resize(kReadAhead);
    cache_len_ = 0;
    SDB_ASSIGN_OR_RETURN(const size_t got,
                         PreadUpTo(path_, fd_.get(), at, kReadAhead, cache_.data()));
    cache_pos_ = at;
    cache_len_ = got;
    if (got < n) return Short(at, n, got);
    std::memcpy(out, cache_.data(), n);
    return Status::OK();
  }

 private:
  static constexpr size_t kReadAhead = 1 << 20;

  Status Short(uint64_t at, size_t n, size_t got) const {
    return Status::Corruption(path_ + ": expected " + std::to_string(n) +
                              " bytes at byte " + std::to_string(at) +
                              ", the file ends at byte " + std::to_string(at + got) +
                              " (truncated after it was opened?)");
  }

  std::string path_;
  Fd fd_;
  uint64_t offset_;
  std::vector<std::byte> cache_;
  uint64_t cache_pos_ = 0;
  size_t cache_len_ = 0;
};

// A gzip stream, decompressed with zlib's gz* functions from `offset` on.
class GzipSource final : public ByteSource {
 public:
  static Result<std::unique_ptr<ByteSource>> Open(const std::string& path, Fd fd,
                                                  uint64_t offset) {
    if (::lseek(fd.get(), static_cast<off_t>(offset), SEEK_SET) < 0) {
      return ErrnoStatus(path, "cannot seek to byte " + std::to_string(offset), errno);
    }
    // gzdopen owns the descriptor from here on (gzclose closes it).
    gzFile gz = gzdopen(fd.get(), "rb");
    if (gz == nullptr) return Status::IOError(path + ": cannot open a gzip stream");
    fd.release();
    auto source = std::unique_ptr<GzipSource>(new GzipSource(path, gz));
    gzbuffer(gz, 256 * 1024);
    // gz* reads non-gzip data "transparently"; a gzip NRRD must be gzip.
    if (gzdirect(gz) == 1) {
      return Status::Corruption(path + ": encoding gzip, but the data at byte " +
                                std::to_string(offset) + " is not a gzip stream");
    }
    return std::unique_ptr<ByteSource>(std::move(source));
  }

  ~GzipSource() override { gzclose(gz_); }

  Status ReadAt(uint64_t pos, size_t n, std::byte* out) override {
    if (pos < pos_) {  // behind: decompress again from the start
      if (gzrewind(gz_) != 0) return Error("cannot rewind the gzip stream");
      pos_ = 0;
    }
    while (pos_ < pos) {  // ahead: decompress and drop the gap
      std::array<std::byte, 64 * 1024> scratch;
      const size_t skip =
          static_cast<size_t>(std::min<uint64_t>(pos - pos_, scratch.size()));
      SDB_RETURN_IF_ERROR(ReadNext(skip, scratch.data()));
    }
    return ReadNext(n, out);
  }

 private:
  GzipSource(std::string path, gzFile gz) : path_(std::move(path)), gz_(gz) {}

  // Reads the next n decompressed bytes.
  Status ReadNext(size_t n, std::byte* out) {
    while (n > 0) {
      const unsigned chunk = static_cast<unsigned>(std::min<size_t>(n, 1u << 30));
      const int r = gzread(gz_, out, chunk);
      if (r < 0) return Error("gzip data error");
      pos_ += static_cast<uint64_t>(r);
      if (static_cast<unsigned>(r) < chunk) {
        return Error("the decompressed stream ends at byte " + std::to_string(pos_) +
                     ", expected " + std::to_string(pos_ + (n - static_cast<size_t>(r))) +
                     " or more");
      }
      out += r;
      n -= static_cast<size_t>(r);
    }
    return Status::OK();
  }

  Status Error(const std::string& what) {
    int code = Z_OK;
    const char* zmsg = gzerror(gz_, &code);
    std::string msg = path_ + ": " + what;
    if (code != Z_OK && zmsg != nullptr && *zmsg != '\0') msg += std::string(" (zlib: ") + zmsg + ")";
    if (code == Z_ERRNO) return Status::IOError(msg);
    return Status::Corruption(msg);
  }

  std::string path_;
  gzFile gz_;
  uint64_t pos_ = 0;  // decompressed bytes read so far
};

}  // namespace
}  // namespace volume_internal

VolumeReader::VolumeReader(VolumeInfo info) : info_(std::move(info)) {
  per_file_ = info_.voxels_per_file();
}

VolumeReader::~VolumeReader() = default;

Result<std::unique_ptr<VolumeReader>> VolumeReader::Open(const VolumeInfo& info) {
  const std::string what = info.description.empty() ? "volume" : info.description;
  SDB_RETURN_IF_ERROR(ValidateGrid(what, info.dimension, info.dims));
  if (!IsValidVoxelType(info.type)) {
    return Status::NotSupported(what + ": voxel type code " +
                                std::to_string(static_cast<int>(info.type)));
  }
  if (info.files.empty() || info.voxel_count() % info.files.size() != 0) {
    return Status::InvalidArgument(what + ": " + std::to_string(info.files.size()) +
                                   " data files do not split " +
                                   FormatDims(info.dimension, info.dims) +
                                   " voxels evenly");
  }
  if (!info.file_offsets.empty() && info.file_offsets.size() != info.files.size()) {
    return Status::InvalidArgument(what + ": " + std::to_string(info.file_offsets.size()) +
                                   " file offsets for " + std::to_string(info.files.size()) +
                                   " data files");
  }
  auto reader = std::unique_ptr<VolumeReader>(new VolumeReader(info));
  SDB_RETURN_IF_ERROR(reader->OpenFile(0));
  return reader;
}

Status VolumeReader::OpenFile(size_t file) {
  source_.reset();
  const std::string& path = info_.files[file];
  SDB_ASSIGN_OR_RETURN(Fd fd, OpenForReading(path));
  if (info_.encoding == Encoding::kGzip) {
    SDB_ASSIGN_OR_RETURN(source_, volume_internal::GzipSource::Open(
                                      path, std::move(fd), info_.offset_of(file)));
  } else {
    source_ = std::make_unique<volume_internal::RawSource>(path, std::move(fd),
                                                           info_.offset_of(file));
  }
  current_file_ = file;
  return Status::OK();
}

Status VolumeReader::Read(uint64_t first, size_t count, double* out) {
  const uint64_t total = info_.voxel_count();
  if (first > total || count > total - first) {
    return Status::InvalidArgument(
        info_.description + ": voxels [" + std::to_string(first) + ", " +
        std::to_string(first + count) + ") are outside the volume's " +
        std::to_string(total) + " voxels");
  }
  // Chunks bound the byte buffer: 64 Ki voxels, at most 512 KiB.
  constexpr size_t kChunkVoxels = 64 * 1024;
  const size_t voxel_size = VoxelSize(info_.type);
  while (count > 0) {
    const size_t file = static_cast<size_t>(first / per_file_);
    const uint64_t in_file = first % per_file_;
    const size_t n = static_cast<size_t>(
        std::min<uint64_t>({count, per_file_ - in_file, kChunkVoxels}));
    if (source_ == nullptr || current_file_ != file) SDB_RETURN_IF_ERROR(OpenFile(file));
    bytes_.resize(n * voxel_size);
    Status s = source_->ReadAt(in_file * voxel_size, n * voxel_size, bytes_.data());
    if (!s.ok()) {
      source_.reset();  // start afresh on the next call
      return s;
    }
    DecodeVoxels(info_.type, info_.order, bytes_.data(), n, out);
    out += n;
    first += n;
    count -= n;
  }
  return Status::OK();
}

}  // namespace simplexdb
