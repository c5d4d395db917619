// The NRRD reader, OpenNrrd (volume.h): attached and detached headers,
// encodings raw and gzip. The header is read in steps: its text
// (ReadNrrdHeader), the fields that matter (ParseNrrdFields), the grid
// (NrrdGrid), then where the voxels are (NrrdData).
#include "storage/volume/volume.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <set>
#include <string_view>
#include <utility>

#include "storage/io/read_only_file.h"
#include "storage/volume/text_internal.h"
#include "storage/volume/volume_info_internal.h"

namespace simplexdb {
namespace {

using Encoding = VolumeInfo::Encoding;
using volume_internal::CheckDataFile;
using volume_internal::DropSingleTimeStep;
using volume_internal::Lower;
using volume_internal::ParseDouble;
using volume_internal::ParseInt;
using volume_internal::Prefixed;
using volume_internal::SetOffsets;
using volume_internal::SplitWhitespace;
using volume_internal::Trim;
using volume_internal::TruncatedData;

// The header's lines (without line ends), and where attached data starts.
struct NrrdHeaderText {
  std::vector<std::string> lines;
  bool ended_by_blank_line = false;
  uint64_t data_start = 0;  // after the blank line, when there is one
};

// Headers are short; the cap stops a wrong file from being read whole.
constexpr size_t kMaxNrrdHeader = 16 << 20;

Result<NrrdHeaderText> ReadNrrdHeader(const std::string& path) {
  SDB_ASSIGN_OR_RETURN(const ReadOnlyFile file, ReadOnlyFile::Open(path));
  NrrdHeaderText h;
  std::string pending;  // a line not yet ended
  uint64_t pos = 0;
  std::vector<std::byte> buf(64 * 1024);
  while (true) {
    SDB_ASSIGN_OR_RETURN(const size_t got,
                         file.ReadUpTo(pos, buf.size(), buf.data()));
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
  const std::string digits = std::to_string(value < 0 ? -value : value);
  const std::string_view sign = value < 0 ? "-" : "";
  const size_t length = sign.size() + digits.size();
  const std::string padding(width > length ? width - length : 0, zero ? '0' : ' ');
  std::string name(format.substr(0, pct));
  if (zero) {
    name += sign;
    name += padding;
  } else {
    name += padding;
    name += sign;
  }
  name += digits;
  name += format.substr(i + 1);
  return name;
}

// Axis kinds of a scalar field's sample grid (NRRD section 6, "kinds").
bool IsDomainKind(std::string_view kind) {
  const std::string k = Lower(kind);
  return k == "domain" || k == "space" || k == "time" || k == "list" ||
         k == "none" || k == "???";
}

// Parses one NRRD vector "(a,b,c)" starting at s[i]; i moves past it.
std::optional<std::vector<double>> ParseNrrdVector(std::string_view s, size_t& i) {
  if (i >= s.size() || s[i] != '(') return std::nullopt;
  const size_t close = s.find(')', i);
  if (close == std::string_view::npos) return std::nullopt;
  std::string_view inner = s.substr(i + 1, close - i - 1);
  std::vector<double> v;
  while (true) {
    const size_t comma = inner.find(',');
    const auto x = ParseDouble(Trim(inner.substr(0, comma)));
    if (!x) return std::nullopt;
    v.push_back(*x);
    if (comma == std::string_view::npos) break;
    inner.remove_prefix(comma + 1);
  }
  i = close + 1;
  return v;
}

// Parses "(a,b,c) (d,e,f) none ..." into the vectors (empty for none).
std::optional<std::vector<std::vector<double>>> ParseSpaceDirections(std::string_view s) {
  std::vector<std::vector<double>> vectors;
  size_t i = 0;
  while (true) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    if (i >= s.size()) break;
    if (s.substr(i, 4) == "none") {
      vectors.emplace_back();
      i += 4;
      continue;
    }
    auto v = ParseNrrdVector(s, i);
    if (!v) return std::nullopt;
    vectors.push_back(std::move(*v));
  }
  return vectors;
}

// The byte position just after the first `lines` newlines at or after
// `start`. Corruption if the file has fewer lines.
Result<uint64_t> SkipLines(const std::string& path, uint64_t start,
                           int64_t lines) {
  if (lines == 0) return start;
  SDB_ASSIGN_OR_RETURN(const ReadOnlyFile file, ReadOnlyFile::Open(path));
  std::vector<std::byte> buf(64 * 1024);
  uint64_t pos = start;
  int64_t seen = 0;
  while (true) {
    SDB_ASSIGN_OR_RETURN(const size_t got,
                         file.ReadUpTo(pos, buf.size(), buf.data()));
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
  std::vector<std::vector<double>> directions;  // "space directions:", empty = none
  std::optional<std::vector<double>> space_origin;
  std::vector<double> axis_mins;
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
        if (!size) return bad('\'' + std::string(part) + "' is not a size");
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
        if (!spacing) return bad('\'' + std::string(part) + "' is not a spacing");
        f.spacings.push_back(*spacing);
      }
    } else if (name == "space directions") {
      auto vectors = ParseSpaceDirections(value);
      if (!vectors) return bad("expected vectors like (1,0,0) or 'none'");
      f.directions = std::move(*vectors);
    } else if (name == "space origin") {
      size_t i = 0;
      auto origin = ParseNrrdVector(value, i);
      if (!origin || i != value.size()) return bad("expected a vector like (0,0,0)");
      f.space_origin = std::move(*origin);
    } else if (name == "axis mins" || name == "axismins") {
      for (std::string_view part : SplitWhitespace(value)) {
        const auto min = ParseDouble(part);
        if (!min) return bad('\'' + std::string(part) + "' is not a number");
        f.axis_mins.push_back(*min);
      }
    }
    // Every other field (content, space, centers, units, labels, min, max,
    // ...) says nothing about where the voxels are or what they mean
    // numerically: ignored.
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
  if (!f.spacings.empty() && f.spacings.size() != d) {
    return count_mismatch("spacings", f.spacings.size());
  }
  if (!f.directions.empty() && f.directions.size() != d) {
    return count_mismatch("space directions", f.directions.size());
  }
  if (!f.axis_mins.empty() && f.axis_mins.size() != d) {
    return count_mismatch("axis mins", f.axis_mins.size());
  }

  VolumeInfo info;
  info.dimension = *f.dimension;
  for (size_t i = 0; i < d; ++i) info.dims[i] = static_cast<uint32_t>(f.sizes[i]);
  // Spacing: the direction vector's length, else "spacings:" (NaN, "none"
  // and non-positive values: unknown, 1). Origin: "axis mins:", then the
  // space axes' "space origin:" over it.
  std::vector<size_t> space_axes;  // the axes with a direction, in order
  for (size_t i = 0; i < d; ++i) {
    double spacing = std::numeric_limits<double>::quiet_NaN();
    if (!f.directions.empty() && !f.directions[i].empty()) {
      double sum = 0;
      for (double x : f.directions[i]) sum += x * x;
      spacing = std::sqrt(sum);
      space_axes.push_back(i);
    } else if (!f.spacings.empty()) {
      spacing = f.spacings[i];
    }
    if (std::isfinite(spacing) && spacing > 0) info.spacing[i] = spacing;
    if (!f.axis_mins.empty() && std::isfinite(f.axis_mins[i])) info.origin[i] = f.axis_mins[i];
  }
  if (f.space_origin) {
    // "space origin:" has one entry per space axis, in the order of the
    // axes with directions (those are the space axes, x, y, z here).
    size_t s = 0;
    for (size_t i = 0; i < d && s < f.space_origin->size(); ++i) {
      if (!f.directions.empty() && f.directions[i].empty()) continue;
      if (std::isfinite((*f.space_origin)[s])) info.origin[i] = (*f.space_origin)[s];
      ++s;
    }
  }
  if (!space_axes.empty()) {
    // The directions as the columns of a 3 x 3 matrix: x, y, z must be the
    // space axes, in a space of 3 dimensions, for an orientation to be kept.
    std::array<std::array<double, 3>, 3> axes{};
    bool three = space_axes.size() == 3;
    for (size_t c = 0; c < space_axes.size() && three; ++c) {
      const std::vector<double>& v = f.directions[space_axes[c]];
      three = space_axes[c] == c && v.size() == 3;
      if (three) std::copy(v.begin(), v.end(), axes[c].begin());
    }
    const volume_internal::AxisAlignment alignment =
        three ? volume_internal::NearestAxisAlignment(axes)
              : volume_internal::AxisAlignment{.unusable = true};
    for (size_t c = 0; c < 3; ++c) info.spacing[c] *= alignment.sign[c];
    info.dropped =
        volume_internal::DescribeDroppedOrientation("the NRRD space directions", alignment);
  }
  info.type = *f.type;
  info.order = f.endian.value_or(ByteOrder::kLittle);
  info.encoding = *f.encoding;
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  return info;
}

// Fills info.files, offsets and description: the attached data, or the
// "data file:" (one name, LIST or format), after line and byte skips;
// checks each data file (CheckDataFile) as soon as it has its name.
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
  // The data files: `file_count` names, the i-th from name_of(i). A format
  // ("s%03d.raw 0 16777216 1") is expanded one name at a time, after its
  // count is checked, so a header cannot make the reader hold millions of
  // names for files that do not exist.
  uint64_t file_count = 1;
  std::function<Result<std::string>(uint64_t)> name_of;
  if (!f.data_file) {
    if (!header.ended_by_blank_line) {
      return Status::InvalidArgument(path +
                                     ": the NRRD header has no 'data file:' field "
                                     "and no blank line before attached data");
    }
    name_of = [&](uint64_t) -> Result<std::string> { return path; };
    base = header.data_start;
    info.description = "NRRD file " + path;
  } else {
    info.description = "NRRD header " + path;
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
      file_count = f.list_files.size();
      name_of = [&](uint64_t i) -> Result<std::string> {
        return resolve(f.list_files[static_cast<size_t>(i)]);
      };
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
      file_count = static_cast<uint64_t>((int64_t{*hi} - *lo) / *step + 1);
      const std::string_view format = parts[0];
      const int64_t first = *lo, stride = *step;
      name_of = [&, format, first, stride](uint64_t i) -> Result<std::string> {
        auto name = ExpandNrrdFormat(format, first + static_cast<int64_t>(i) * stride);
        if (!name.ok()) return Prefixed(name.status(), path + ": ");
        return resolve(*name);
      };
      subdim = given_subdim.value_or(d - 1);
    } else {
      name_of = [&](uint64_t) -> Result<std::string> { return resolve(*f.data_file); };
    }
  }
  uint64_t files_needed = 1;
  for (size_t i = subdim; i < d; ++i) files_needed *= f.sizes[i];
  if (file_count != files_needed) {
    return Status::InvalidArgument(
        path + ": " + std::to_string(file_count) + " data files, expected " +
        std::to_string(files_needed) + " (one per " + std::to_string(subdim) +
        "D slab of " + FormatDims(info.dimension, info.dims) + ")");
  }
  if (f.byte_skip != 0 && info.encoding == Encoding::kGzip) {
    return Status::NotSupported(path + ": 'byte skip: " + std::to_string(f.byte_skip) +
                                "' with gzip encoding (a skip inside the "
                                "decompressed stream) is not supported");
  }
  const uint64_t bytes_per_file =
      info.voxel_count() / file_count * VoxelSize(info.type);
  std::vector<uint64_t> offsets;
  for (uint64_t i = 0; i < file_count; ++i) {
    SDB_ASSIGN_OR_RETURN(std::string file, name_of(i));
    SDB_ASSIGN_OR_RETURN(uint64_t start, SkipLines(file, base, f.line_skip));
    if (f.byte_skip == -1) {  // raw only (checked above)
      SDB_ASSIGN_OR_RETURN(const ReadOnlyFile data, ReadOnlyFile::Open(file));
      SDB_ASSIGN_OR_RETURN(const uint64_t size, data.Size());
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
    // Checked now, so that the first missing or short file ends the loop.
    SDB_RETURN_IF_ERROR(CheckDataFile(info, file_count, file, start, TruncatedData));
    info.files.push_back(std::move(file));
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
  // NrrdData checks each data file (CheckDataFile) as it names it.
  SDB_RETURN_IF_ERROR(NrrdData(path, header, fields, info));
  return info;
}

}  // namespace simplexdb
