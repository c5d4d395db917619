// VolumeReader (volume.h): voxels as doubles from the data files a
// VolumeInfo names, through a ByteSource per open file (raw with read-ahead,
// or a gzip stream).
#include "storage/volume/volume.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "storage/io/read_only_file.h"
#include "storage/volume/generate.h"

namespace simplexdb {

using Encoding = VolumeInfo::Encoding;

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
  RawSource(ReadOnlyFile file, uint64_t offset)
      : file_(std::move(file)), offset_(offset) {}

  Status ReadAt(uint64_t pos, size_t n, std::byte* out) override {
    const uint64_t at = offset_ + pos;
    if (at >= cache_pos_ && at + n <= cache_pos_ + cache_len_) {
      std::memcpy(out, cache_.data() + (at - cache_pos_), n);
      return Status::OK();
    }
    if (n >= kReadAhead) {  // large reads go straight to the caller
      SDB_ASSIGN_OR_RETURN(const size_t got, file_.ReadUpTo(at, n, out));
      return got == n ? Status::OK() : Short(at, n, got);
    }
    cache_.resize(kReadAhead);
    cache_len_ = 0;
    SDB_ASSIGN_OR_RETURN(const size_t got, file_.ReadUpTo(at, kReadAhead, cache_.data()));
    cache_pos_ = at;
    cache_len_ = got;
    if (got < n) return Short(at, n, got);
    std::memcpy(out, cache_.data(), n);
    return Status::OK();
  }

 private:
  static constexpr size_t kReadAhead = 1 << 20;

  Status Short(uint64_t at, size_t n, size_t got) const {
    return Status::Corruption(file_.path() + ": expected " + std::to_string(n) +
                              " bytes at byte " + std::to_string(at) +
                              ", the file ends at byte " + std::to_string(at + got) +
                              " (truncated after it was opened?)");
  }

  ReadOnlyFile file_;
  uint64_t offset_;
  std::vector<std::byte> cache_;
  uint64_t cache_pos_ = 0;
  size_t cache_len_ = 0;
};

// A gzip stream, decompressed with zlib's gz* functions from `offset` on.
class GzipSource final : public ByteSource {
 public:
  static Result<std::unique_ptr<ByteSource>> Open(ReadOnlyFile file, uint64_t offset) {
    SDB_RETURN_IF_ERROR(file.Seek(offset));
    const std::string& path = file.path();
    // gzdopen owns the descriptor from here on (gzclose closes it).
    gzFile gz = gzdopen(file.fd(), "rb");
    if (gz == nullptr) return Status::IOError(path + ": cannot open a gzip stream");
    file.Release();
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

// Voxels in memory (VolumeInfo::kMemory): a copy out of the caller's
// buffer, which outlives the reader (MemoryVolume's contract).
class MemorySource final : public ByteSource {
 public:
  MemorySource(const std::byte* bytes, uint64_t size) : bytes_(bytes), size_(size) {}

  Status ReadAt(uint64_t pos, size_t n, std::byte* out) override {
    if (pos > size_ || n > size_ - pos) {  // Read() checks the range: a bug
      return Status::Corruption("volume in memory: bytes [" + std::to_string(pos) + ", " +
                                std::to_string(pos + n) + ") are beyond its " +
                                std::to_string(size_) + " bytes");
    }
    std::memcpy(out, bytes_ + pos, n);
    return Status::OK();
  }

 private:
  const std::byte* bytes_;
  uint64_t size_;
};

// A generated field (VolumeInfo::kGenerated): the voxels of the range
// computed, rounded to the volume's type and encoded as its bytes.
class GeneratedSource final : public ByteSource {
 public:
  GeneratedSource(std::shared_ptr<const FieldGenerator> generator, VoxelType type, ByteOrder order)
      : generator_(std::move(generator)), type_(type), order_(order) {}

  Status ReadAt(uint64_t pos, size_t n, std::byte* out) override {
    const size_t size = VoxelSize(type_);
    const size_t count = n / size;
    values_.resize(count);
    generator_->Fill(pos / size, count, values_.data());
    for (double& v : values_) v = RepresentableValue(type_, v);
    EncodeVoxels(type_, order_, values_.data(), count, out);
    return Status::OK();
  }

 private:
  std::shared_ptr<const FieldGenerator> generator_;
  VoxelType type_;
  ByteOrder order_;
  std::vector<double> values_;
};

}  // namespace
}  // namespace volume_internal

// Whether the voxels come from no file (memory, or a generated field).
bool VolumeReader::FileLess() const {
  return info_.encoding == Encoding::kMemory || info_.encoding == Encoding::kGenerated;
}

VolumeReader::VolumeReader(VolumeInfo info) : info_(std::move(info)) {
  per_file_ = FileLess() ? info_.voxel_count() : info_.voxels_per_file();
}

VolumeReader::~VolumeReader() = default;

Result<std::unique_ptr<VolumeReader>> VolumeReader::Open(const VolumeInfo& info) {
  const std::string what = info.description.empty() ? "volume" : info.description;
  SDB_RETURN_IF_ERROR(ValidateGrid(what, info.dimension, info.dims));
  if (!IsValidVoxelType(info.type)) {
    return Status::NotSupported(what + ": voxel type code " +
                                std::to_string(static_cast<int>(info.type)));
  }
  if (info.encoding == Encoding::kMemory) {
    if (info.memory == nullptr || !info.files.empty()) {
      return Status::InvalidArgument(what + ": a volume in memory has its bytes and no data files");
    }
    auto reader = std::unique_ptr<VolumeReader>(new VolumeReader(info));
    reader->source_ = std::make_unique<volume_internal::MemorySource>(
        info.memory.get(), info.voxel_count() * VoxelSize(info.type));
    return reader;
  }
  if (info.encoding == Encoding::kGenerated) {
    if (info.generator == nullptr || !info.files.empty()) {
      return Status::InvalidArgument(what + ": a generated volume has its generator and no data files");
    }
    auto reader = std::unique_ptr<VolumeReader>(new VolumeReader(info));
    reader->source_ = std::make_unique<volume_internal::GeneratedSource>(info.generator, info.type, info.order);
    return reader;
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
  SDB_ASSIGN_OR_RETURN(ReadOnlyFile data, ReadOnlyFile::Open(path));
  if (info_.encoding == Encoding::kGzip) {
    SDB_ASSIGN_OR_RETURN(source_, volume_internal::GzipSource::Open(
                                      std::move(data), info_.offset_of(file)));
  } else {
    source_ = std::make_unique<volume_internal::RawSource>(std::move(data),
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
    if (!FileLess() && (source_ == nullptr || current_file_ != file)) {
      SDB_RETURN_IF_ERROR(OpenFile(file));
    }
    bytes_.resize(n * voxel_size);
    Status s = source_->ReadAt(in_file * voxel_size, n * voxel_size, bytes_.data());
    if (!s.ok()) {
      if (!FileLess()) source_.reset();  // start afresh on the next call
      return s;
    }
    DecodeVoxels(info_.type, info_.order, bytes_.data(), n, out);
    if (info_.scaled()) {
      for (size_t i = 0; i < n; ++i) out[i] = info_.scale * out[i] + info_.shift;
    }
    out += n;
    first += n;
    count -= n;
  }
  return Status::OK();
}

}  // namespace simplexdb
