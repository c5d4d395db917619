#include "query/vtk_xml_internal.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <chrono>
#include <cstdio>
#include <thread>

#include "storage/common/parallel_run.h"
#include "util/out_of_memory.h"

namespace simplexdb::internal {
namespace {

// zlib's deflate with its state kept between blocks (deflateReset, not a
// fresh deflateInit's 256 KiB per block). One per worker thread.
class Deflater {
 public:
  Deflater() = default;
  Deflater(const Deflater&) = delete;
  Deflater& operator=(const Deflater&) = delete;
  ~Deflater() {
    if (ready_) deflateEnd(&z_);
  }

  // `out` = the zlib stream (RFC 1950: what vtkZLibDataCompressor's
  // uncompress reads) of in[0, n). REQUIRES: n < 2^32.
  Status Compress(const uint8_t* in, size_t n, int level, const std::string& path, std::vector<uint8_t>& out) {
    if (!ready_) {
      if (deflateInit(&z_, level) != Z_OK) return NotEnoughMemory(path + ": zlib's compressor state", "256 KiB");
      ready_ = true;
    } else if (deflateReset(&z_) != Z_OK) {
      return Status::IOError(path + ": zlib's deflateReset failed");
    }
    buffer_.resize(deflateBound(&z_, static_cast<uLong>(n)));
    z_.next_in = const_cast<Bytef*>(in);  // zlib's API is not const; it only reads
    z_.avail_in = static_cast<uInt>(n);
    z_.next_out = buffer_.data();
    z_.avail_out = static_cast<uInt>(buffer_.size());
    // deflateBound is room for any input, so one Z_FINISH call ends the stream.
    if (const int rc = deflate(&z_, Z_FINISH); rc != Z_STREAM_END) {
      return Status::IOError(path + ": zlib's deflate failed (" + std::to_string(rc) + ")");
    }
    out.assign(buffer_.data(), buffer_.data() + z_.total_out);
    return Status::OK();
  }

 private:
  z_stream z_{};
  bool ready_ = false;
  std::vector<uint8_t> buffer_;
};

}  // namespace

Result<OutputFile> OutputFile::Open(const std::string& path) {
  OutputFile o;
  if (path != "-") {
    SDB_ASSIGN_OR_RETURN(o.file_, AtomicFileWriter::Create(path));
  }
  return o;
}

Status OutputFile::Write(const void* data, size_t n) {
  const auto* p = static_cast<const uint8_t*>(data);
  buffer_.insert(buffer_.end(), p, p + n);
  if (buffer_.size() >= (size_t{4} << 20)) return Flush();
  return Status::OK();
}

Status OutputFile::Commit() {
  SDB_RETURN_IF_ERROR(Flush());
  if (!file_) {
    if (std::fflush(stdout) != 0) return Status::IOError("writing to standard output failed");
    return Status::OK();
  }
  return file_->Commit();
}

Status OutputFile::Flush() {
  if (buffer_.empty()) return Status::OK();
  if (file_) {
    SDB_ASSIGN_OR_RETURN(const uint64_t at, file_->Append(buffer_));
    (void)at;
  } else if (std::fwrite(buffer_.data(), 1, buffer_.size(), stdout) != buffer_.size()) {
    return Status::IOError("writing to standard output failed");
  }
  buffer_.clear();
  return Status::OK();
}

void AddCellArrays(std::vector<AppendedArray>& arrays, const std::vector<int64_t>& connectivity, int corners,
                   uint64_t points, uint64_t int32_limit) {
  const uint64_t cells = connectivity.size() / corners, n = static_cast<uint64_t>(corners);
  const int64_t* c = connectivity.data();
  if (points <= int32_limit && connectivity.size() <= int32_limit) {
    arrays.push_back(Made<int32_t>(Element("Int32", "connectivity"), connectivity.size(), [c](uint64_t i) { return c[i]; }));
    arrays.push_back(Made<int32_t>(Element("Int32", "offsets"), cells, [n](uint64_t i) { return n * (i + 1); }));
  } else {
    arrays.push_back(Stored(Element("Int64", "connectivity"), connectivity));
    arrays.push_back(Made<int64_t>(Element("Int64", "offsets"), cells, [n](uint64_t i) { return n * (i + 1); }));
  }
}

std::string Element(const char* type, const char* name, int components) {
  std::string e = std::string("<DataArray type=\"") + type + "\"";
  if (name != nullptr) e += std::string(" Name=\"") + name + "\"";
  if (components != 1) e += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  return e + " format=\"appended\"";
}

Status WriteAppendedVtk(const std::string& path, const std::vector<AppendedArray>& arrays, const VtuOptions& options,
                        const std::function<std::string(const std::vector<std::string>& elements)>& xml) {
  static_assert(std::endian::native == std::endian::little, "VTK files here are little-endian");
  assert(options.block_bytes > 0 && options.block_bytes % 8 == 0);
  // Every block of every array is one work item.
  const uint64_t block = options.block_bytes;
  std::vector<uint64_t> first_item(arrays.size() + 1, 0);
  for (size_t a = 0; a < arrays.size(); ++a) {
    first_item[a + 1] = first_item[a] + (arrays[a].bytes + block - 1) / block;
  }
  std::vector<std::vector<uint8_t>> compressed(first_item.back());
  int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = static_cast<int>(std::clamp<uint64_t>(compressed.size(), 1, std::max(threads, 1)));
  std::vector<Deflater> deflaters(static_cast<size_t>(threads));
  std::vector<std::vector<uint8_t>> scratch(static_cast<size_t>(threads));
  SDB_RETURN_IF_ERROR(RunParallel(
      compressed.size(), threads, "vtk compression", std::chrono::steady_clock::now(), {},
      [&](int w, uint64_t item) -> Status {
        const size_t a = std::upper_bound(first_item.begin(), first_item.end(), item) - first_item.begin() - 1;
        const uint64_t first = (item - first_item[a]) * block;
        const size_t n = static_cast<size_t>(std::min(block, arrays[a].bytes - first));
        scratch[w].resize(block);
        const uint8_t* bytes = arrays[a].bytes_at(first, n, scratch[w].data());
        return deflaters[w].Compress(bytes, n, options.level, path, compressed[item]);
      }));

  // The headers, and each array's offset from the start of the appended data.
  std::vector<std::vector<uint64_t>> headers(arrays.size());
  std::vector<std::string> elements(arrays.size());
  uint64_t at = 0;
  for (size_t a = 0; a < arrays.size(); ++a) {
    std::vector<uint64_t>& h = headers[a];
    h = {first_item[a + 1] - first_item[a], block, arrays[a].bytes % block};
    for (uint64_t i = first_item[a]; i < first_item[a + 1]; ++i) h.push_back(compressed[i].size());
    elements[a] = arrays[a].element + " offset=\"" + std::to_string(at) + "\"/>\n";
    at += 8 * h.size();
    for (size_t i = 3; i < h.size(); ++i) at += h[i];
  }
  SDB_ASSIGN_OR_RETURN(OutputFile out, OutputFile::Open(path));
  SDB_RETURN_IF_ERROR(out.Write(xml(elements)));
  for (size_t a = 0; a < arrays.size(); ++a) {
    SDB_RETURN_IF_ERROR(out.Write(headers[a].data(), 8 * headers[a].size()));
    for (uint64_t i = first_item[a]; i < first_item[a + 1]; ++i) {
      SDB_RETURN_IF_ERROR(out.Write(compressed[i].data(), compressed[i].size()));
      std::vector<uint8_t>().swap(compressed[i]);  // written: let it go
    }
  }
  SDB_RETURN_IF_ERROR(out.Write("\n</AppendedData>\n</VTKFile>\n"));
  return out.Commit();
}

}  // namespace simplexdb::internal
