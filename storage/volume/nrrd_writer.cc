#include "storage/volume/nrrd_writer.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

namespace simplexdb {
namespace {

// errno is translated into a Status here, once.
Status WriteError(const std::string& path, std::string_view what, int err) {
  const std::string msg = path + ": " + std::string(what) + ": " +
                          std::error_code(err, std::generic_category()).message();
  if (err == ENOSPC || err == EDQUOT) return Status::ResourceExhausted(msg);
  return Status::IOError(msg);
}

// A file written under a temporary name and renamed into place by Commit().
// Destroying it uncommitted removes the temporary file.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path) : path_(std::move(path)) {}
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!tmp_.empty() && !committed_) ::unlink(tmp_.c_str());
  }

  Status Create() {
    std::string name = path_ + ".tmp-XXXXXX";
    const int fd = ::mkstemp(name.data());
    if (fd < 0) return WriteError(path_, "cannot create a temporary file", errno);
    fd_ = fd;
    tmp_ = std::move(name);
    // mkstemp makes the file 0600; a volume is an ordinary file.
    if (::fchmod(fd_, 0644) != 0) return WriteError(tmp_, "cannot chmod", errno);
    return Status::OK();
  }

  Status Append(const void* data, size_t n) {
    const auto* p = static_cast<const char*>(data);
    while (n > 0) {
      const ssize_t w = ::write(fd_, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        return WriteError(path_, "write failed", errno);
      }
      p += w;
      n -= static_cast<size_t>(w);
    }
    return Status::OK();
  }

  // fsync, close, rename over path_, fsync the directory so the rename
  // itself is durable.
  Status Commit() {
    if (::fsync(fd_) != 0) return WriteError(path_, "fsync failed", errno);
    const int fd = std::exchange(fd_, -1);
    if (::close(fd) != 0) return WriteError(path_, "close failed", errno);
    if (::rename(tmp_.c_str(), path_.c_str()) != 0) {
      return WriteError(path_, "cannot rename " + tmp_ + " to it", errno);
    }
    committed_ = true;
    std::filesystem::path dir = std::filesystem::path(path_).parent_path();
    if (dir.empty()) dir = ".";
    const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd < 0) return WriteError(dir.string(), "cannot open the directory", errno);
    const int r = ::fsync(dfd);
    const int err = errno;
    ::close(dfd);
    // Some file systems cannot fsync a directory (EINVAL): nothing to do.
    if (r != 0 && err != EINVAL) {
      return WriteError(dir.string(), "fsync of the directory failed", err);
    }
    return Status::OK();
  }

 private:
  std::string path_;
  std::string tmp_;  // empty until Create()
  int fd_ = -1;
  bool committed_ = false;
};

// Shortest text that reads back as the same double.
std::string FormatDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

Status CheckInput(const std::string& path, int dimension,
                  const std::array<uint32_t, 4>& dims, VoxelType type,
                  std::span<const double> values,
                  const std::array<double, 4>& spacing) {
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

// The header up to and including its last field line.
std::string NrrdHeader(int dimension, const std::array<uint32_t, 4>& dims,
                       VoxelType type, const std::array<double, 4>& spacing) {
  std::string sizes, spacings, kinds;
  for (int i = 0; i < dimension; ++i) {
    const auto a = static_cast<size_t>(i);
    const char* sep = i == 0 ? "" : " ";
    sizes += sep + std::to_string(dims[a]);
    spacings += sep + FormatDouble(spacing[a]);
    kinds += std::string(sep) + "domain";
  }
  std::string h = "NRRD0004\n# Written by SimplexDB.\n";
  h += "type: " + std::string(NrrdTypeName(type)) + "\n";
  h += "dimension: " + std::to_string(dimension) + "\n";
  h += "sizes: " + sizes + "\n";
  h += "spacings: " + spacings + "\n";
  h += "kinds: " + kinds + "\n";
  // "endian:" is required exactly when the type has more than one byte.
  if (VoxelSize(type) > 1) h += "endian: little\n";
  h += "encoding: raw\n";
  return h;
}

// Appends the values to `file` as little-endian `type`, 64 Ki voxels at a
// time.
Status AppendVoxels(AtomicFile& file, VoxelType type,
                    std::span<const double> values) {
  constexpr size_t kChunk = 64 * 1024;  // voxels per write
  std::vector<std::byte> bytes;
  for (size_t i = 0; i < values.size(); i += kChunk) {
    const size_t n = std::min(kChunk, values.size() - i);
    bytes.resize(n * VoxelSize(type));
    EncodeVoxels(type, ByteOrder::kLittle, values.data() + i, n, bytes.data());
    SDB_RETURN_IF_ERROR(file.Append(bytes.data(), bytes.size()));
  }
  return Status::OK();
}

// The "data file:" value naming `raw_path` from the header `nhdr_path`.
Result<std::string> DataFileName(const std::string& raw_path,
                                 const std::string& nhdr_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path raw = fs::absolute(raw_path, ec).lexically_normal();
  if (ec) return WriteError(raw_path, "cannot make the path absolute", ec.value());
  const fs::path dir = fs::absolute(nhdr_path, ec).lexically_normal().parent_path();
  if (ec) return WriteError(nhdr_path, "cannot make the path absolute", ec.value());
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

Status WriteNrrd(const std::string& path, int dimension,
                 std::array<uint32_t, 4> dims, VoxelType type,
                 std::span<const double> values, std::array<double, 4> spacing) {
  SDB_RETURN_IF_ERROR(CheckInput(path, dimension, dims, type, values, spacing));
  // A blank line ends an attached header; the voxels follow it.
  const std::string header = NrrdHeader(dimension, dims, type, spacing) + "\n";
  AtomicFile file(path);
  SDB_RETURN_IF_ERROR(file.Create());
  SDB_RETURN_IF_ERROR(file.Append(header.data(), header.size()));
  SDB_RETURN_IF_ERROR(AppendVoxels(file, type, values));
  return file.Commit();
}

Status WriteRawWithNhdr(const std::string& raw_path, const std::string& nhdr_path,
                        int dimension, std::array<uint32_t, 4> dims,
                        VoxelType type, std::span<const double> values,
                        std::array<double, 4> spacing) {
  SDB_RETURN_IF_ERROR(CheckInput(nhdr_path, dimension, dims, type, values, spacing));
  SDB_ASSIGN_OR_RETURN(const std::string data_file, DataFileName(raw_path, nhdr_path));
  {
    AtomicFile raw(raw_path);
    SDB_RETURN_IF_ERROR(raw.Create());
    SDB_RETURN_IF_ERROR(AppendVoxels(raw, type, values));
    SDB_RETURN_IF_ERROR(raw.Commit());
  }
  const std::string header =
      NrrdHeader(dimension, dims, type, spacing) + "data file: " + data_file + "\n";
  AtomicFile nhdr(nhdr_path);
  SDB_RETURN_IF_ERROR(nhdr.Create());
  SDB_RETURN_IF_ERROR(nhdr.Append(header.data(), header.size()));
  return nhdr.Commit();
}

}  // namespace simplexdb
