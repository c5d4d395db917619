#include "query/mesh_io.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <memory>
#include <new>
#include <thread>

#include "query/mesh_io_internal.h"
#include "storage/common/parallel_run.h"
#include "storage/io/file.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

// Buffers text or bytes and appends them to an AtomicFileWriter in large
// pieces (or writes them to stdout).
class Output {
 public:
  static Result<Output> Open(const std::string& path) {
    Output o;
    if (path != "-") {
      SDB_ASSIGN_OR_RETURN(o.file_, AtomicFileWriter::Create(path));
    }
    return o;
  }
  Status Write(const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    buffer_.insert(buffer_.end(), p, p + n);
    if (buffer_.size() >= (size_t{4} << 20)) return Flush();
    return Status::OK();
  }
  Status Write(std::string_view s) { return Write(s.data(), s.size()); }
  Status Commit() {
    SDB_RETURN_IF_ERROR(Flush());
    if (!file_) {
      if (std::fflush(stdout) != 0) return Status::IOError("writing to standard output failed");
      return Status::OK();
    }
    return file_->Commit();
  }

 private:
  Status Flush() {
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

  std::unique_ptr<AtomicFileWriter> file_;
  std::vector<uint8_t> buffer_;
};

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

// One array of the appended data: its DataArray element up to the offset
// attribute, and its bytes, which bytes_at gives block by block.
struct AppendedArray {
  std::string element;
  uint64_t bytes = 0;
  // The array's bytes [first, first + n): a pointer into the mesh, or
  // `scratch` (n bytes) filled. Called from several threads at once.
  // REQUIRES: first and n multiples of the array's word size.
  std::function<const uint8_t*(uint64_t first, size_t n, uint8_t* scratch)> bytes_at;
};

// An array of the mesh, as stored.
template <class T>
AppendedArray Stored(std::string element, const std::vector<T>& v) {
  const auto* p = reinterpret_cast<const uint8_t*>(v.data());
  return {std::move(element), v.size() * sizeof(T), [p](uint64_t first, size_t, uint8_t*) { return p + first; }};
}

// An array made on the fly: element i is static_cast<Out>(value(i)).
template <class Out, class Value>
AppendedArray Made(std::string element, uint64_t count, Value value) {
  return {std::move(element), count * sizeof(Out), [value](uint64_t first, size_t n, uint8_t* scratch) {
            const uint64_t i0 = first / sizeof(Out);
            for (size_t k = 0; k < n / sizeof(Out); ++k) {
              const Out o = static_cast<Out>(value(i0 + k));
              std::memcpy(scratch + k * sizeof(Out), &o, sizeof o);
            }
            return static_cast<const uint8_t*>(scratch);
          }};
}

// `<DataArray type="T" [Name="N"] [NumberOfComponents="C"] format="appended"`
std::string Element(const char* type, const char* name, int components = 1) {
  std::string e = std::string("<DataArray type=\"") + type + "\"";
  if (name != nullptr) e += std::string(" Name=\"") + name + "\"";
  if (components != 1) e += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  return e + " format=\"appended\"";
}

}  // namespace

template <int D>
Status WriteCodes(std::span<const SimplexCode<D>> codes, const std::string& path) {
  SDB_ASSIGN_OR_RETURN(Output out, Output::Open(path));
  std::string line;
  for (const SimplexCode<D> c : codes) {
    line = c.ToString();
    line.push_back('\n');
    SDB_RETURN_IF_ERROR(out.Write(line));
  }
  return out.Commit();
}

template Status WriteCodes<3>(std::span<const SimplexCode<3>>, const std::string&);
template Status WriteCodes<4>(std::span<const SimplexCode<4>>, const std::string&);

namespace internal {

// Level and block size, measured on a 5.0M-tetrahedron mesh (perlin 129^3
// float32 at --error 1%: 320 MB uncompressed), one thread, CPU seconds:
//
//   block    level 1           level 6
//   32 KiB   54.4 MB  2.3 s    52.7 MB  9.4 s
//   64 KiB   53.5 MB  2.2 s    51.8 MB 10.2 s
//   256 KiB  52.9 MB  1.6 s    51.0 MB 10.8 s
//   1 MiB    52.7 MB  1.6 s
//
// Level 6 saves 3-4% for five to seven times the time, so level 1 (level
// 2: 52.0 MB, 1.8 s). Blocks of 256 KiB rather than VTK's 32 KiB: each block
// pays a deflateReset and starts without history, which costs 3% in size
// and 40% in time at 32 KiB; past 256 KiB nothing is left to gain, and
// VTK's reader holds one block at a time, so blocks stay small beside the
// arrays. A mesh of a million tetrahedra still makes some 170 blocks to share
// among the threads.
constexpr size_t kVtuBlockBytes = size_t{256} << 10;
constexpr int kVtuLevel = 1;

VtuOptions DefaultVtuOptions() { return {kVtuBlockBytes, kVtuLevel, INT32_MAX, 0}; }

namespace {

// VTK's binary appended format with vtkZLibDataCompressor and UInt64
// headers (vtkXMLWriter::CreateCompressionHeader): each array is the
// header [blocks, block size, size of the last block if partial else 0,
// compressed size of each block], 8 bytes a word, then the blocks' zlib
// streams, each block compressed alone. May throw std::bad_alloc.
Status WriteCompressedVtu(const TetMeshData& mesh, const std::string& path, const VtuOptions& options) {
  static_assert(std::endian::native == std::endian::little, "VTK files here are little-endian");
  assert(options.block_bytes > 0 && options.block_bytes % 8 == 0);
  const uint64_t n_points = mesh.field.size(), n_cells = mesh.cells();
  // Point indices are below n_points (CollectTetMesh, SliceHpMesh), so
  // the narrowing casts below keep every index and offset.
  const bool int32 = n_points <= options.int32_limit && 4 * n_cells <= options.int32_limit;
  const int64_t* connectivity = mesh.connectivity.data();

  // In the order of the file; the XML elements are nested around them below.
  std::vector<AppendedArray> arrays;
  arrays.push_back(Stored(Element("Float64", "field"), mesh.field));
  arrays.push_back(Stored(Element("Float64", "error"), mesh.error));
  arrays.push_back(Stored(Element("UInt8", "level"), mesh.level));
  arrays.push_back(Stored(Element("UInt64", "code"), mesh.code));
  arrays.push_back(Stored(Element("Float64", nullptr, 3), mesh.points));
  if (int32) {
    arrays.push_back(Made<int32_t>(Element("Int32", "connectivity"), 4 * n_cells,
                                   [connectivity](uint64_t i) { return connectivity[i]; }));
    arrays.push_back(Made<int32_t>(Element("Int32", "offsets"), n_cells, [](uint64_t i) { return 4 * (i + 1); }));
  } else {
    arrays.push_back(Stored(Element("Int64", "connectivity"), mesh.connectivity));
    arrays.push_back(Made<int64_t>(Element("Int64", "offsets"), n_cells, [](uint64_t i) { return 4 * (i + 1); }));
  }
  arrays.push_back(Made<uint8_t>(Element("UInt8", "types"), n_cells, [](uint64_t) { return 10; }));  // VTK_TETRA

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
      compressed.size(), threads, "vtu compression", std::chrono::steady_clock::now(), {},
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
  std::vector<uint64_t> offsets(arrays.size());
  uint64_t at = 0;
  for (size_t a = 0; a < arrays.size(); ++a) {
    std::vector<uint64_t>& h = headers[a];
    h = {first_item[a + 1] - first_item[a], block, arrays[a].bytes % block};
    for (uint64_t i = first_item[a]; i < first_item[a + 1]; ++i) h.push_back(compressed[i].size());
    offsets[a] = at;
    at += 8 * h.size();
    for (size_t i = 3; i < h.size(); ++i) at += h[i];
  }
  const auto element = [&](size_t a) {
    return arrays[a].element + " offset=\"" + std::to_string(offsets[a]) + "\"/>\n";
  };
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\" "
         "compressor=\"vtkZLibDataCompressor\">\n";
  xml += "<UnstructuredGrid>\n";
  xml += "<Piece NumberOfPoints=\"" + std::to_string(n_points) + "\" NumberOfCells=\"" + std::to_string(n_cells) +
         "\">\n";
  xml += "<PointData Scalars=\"field\">\n" + element(0);
  xml += "</PointData>\n<CellData Scalars=\"error\">\n" + element(1) + element(2) + element(3);
  xml += "</CellData>\n<Points>\n" + element(4);
  xml += "</Points>\n<Cells>\n" + element(5) + element(6) + element(7);
  xml += "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";

  SDB_ASSIGN_OR_RETURN(Output out, Output::Open(path));
  SDB_RETURN_IF_ERROR(out.Write(xml));
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

}  // namespace

Status WriteVtu(const TetMeshData& mesh, const std::string& path, const VtuOptions& options) {
  try {
    return WriteCompressedVtu(mesh, path, options);
  } catch (const std::bad_alloc&) {
    // The compressed arrays, the headers or the output buffer.
    return NotEnoughMemory(path + ": the compressed arrays of " + std::to_string(mesh.cells()) + " tetrahedra",
                           "about 11 bytes a tetrahedron");
  }
}

}  // namespace internal

Status WriteVtu(const TetMeshData& mesh, const std::string& path) {
  return internal::WriteVtu(mesh, path, internal::DefaultVtuOptions());
}

}  // namespace simplexdb
