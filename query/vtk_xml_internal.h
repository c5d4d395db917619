// VTK XML files with binary appended data compressed by zlib, and the
// buffered output files behind them: what the .vtu (query/mesh_io.h) and
// .vtp (query/surface_io.h) writers share. Internal to query/.
//
// Thread safety: an OutputFile is one thread's; WriteAppendedVtk compresses
// on several threads and calls bytes_at from them.
//
// Errors: the writer's (storage/io/file.h: the errno of the failing call
// naming the file, ResourceExhausted for a full disk), IOError when writing
// to standard output fails or zlib fails; nothing is left under the path.
// May throw std::bad_alloc (the callers turn it into ResourceExhausted).
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "query/mesh_io_internal.h"
#include "storage/io/file.h"
#include "util/status.h"

namespace simplexdb::internal {

// Buffers text or bytes and appends them to an AtomicFileWriter in large
// pieces, or writes them to standard output ("-").
class OutputFile {
 public:
  static Result<OutputFile> Open(const std::string& path);
  Status Write(const void* data, size_t n);
  Status Write(std::string_view s) { return Write(s.data(), s.size()); }
  // Flushes and commits the file (renames it into place).
  Status Commit();

 private:
  Status Flush();

  std::unique_ptr<AtomicFileWriter> file_;
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

// An array as stored.
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

// The cells' "connectivity" and "offsets" arrays, `corners` point indices a
// cell: Int32 when `points` and the connectivity's length are at most
// `int32_limit`, else Int64 (the indices are below `points`, so the narrowing
// keeps them). Reads `connectivity` when written: it must outlive the write.
void AddCellArrays(std::vector<AppendedArray>& arrays, const std::vector<int64_t>& connectivity, int corners,
                   uint64_t points, uint64_t int32_limit);

// `<DataArray type="T" [Name="N"] [NumberOfComponents="C"] format="appended"`
std::string Element(const char* type, const char* name, int components = 1);

// Writes `path`: the XML that `xml` returns, then the appended data of
// `arrays` in order and the closing tags. xml(elements) gets each array's
// complete DataArray element (with its offset) and returns the document up
// to and including `<AppendedData encoding="raw">\n_`. VTK's binary
// appended format with vtkZLibDataCompressor and UInt64 headers
// (vtkXMLWriter::CreateCompressionHeader): each array is the header
// [blocks, block size, size of the last block if partial else 0,
// compressed size of each block], 8 bytes a word, then the blocks' zlib
// streams, each block compressed alone.
Status WriteAppendedVtk(const std::string& path, const std::vector<AppendedArray>& arrays, const VtuOptions& options,
                        const std::function<std::string(const std::vector<std::string>& elements)>& xml);

}  // namespace simplexdb::internal
