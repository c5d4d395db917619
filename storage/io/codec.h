// zstd compression of blocks, with RAII contexts. Each compressed block is
// one independent frame that records its content size and a content
// checksum, so a frame can be decoded alone and a damaged one is detected.
// zstd's error codes become a Status here and nowhere else.
//
// Errors: ResourceExhausted when zstd cannot allocate its context (the
// constructors do not fail; the first call reports it); Corruption for a
// frame that does not decode to the size asked for; IOError when zstd
// refuses to compress (its error name in the message).
//
// Lifetimes: Compress returns a new vector it owns; Decompress writes into
// the caller's span and keeps nothing.
//
// Thread safety: a Compressor or Decompressor is used by one thread at a
// time (each holds a zstd context); make one per thread.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "util/status.h"

struct ZSTD_CCtx_s;
struct ZSTD_DCtx_s;

namespace simplexdb {

class ZstdCompressor {
 public:
  // `level`: zstd's compression level (1 fast .. 19 small; 3 is zstd's default).
  explicit ZstdCompressor(int level = 3);
  ~ZstdCompressor();
  ZstdCompressor(const ZstdCompressor&) = delete;
  ZstdCompressor& operator=(const ZstdCompressor&) = delete;

  // Compresses `src` into one frame. Errors: ResourceExhausted (no
  // context), IOError (zstd failed).
  Result<std::vector<uint8_t>> Compress(std::span<const uint8_t> src);

 private:
  ZSTD_CCtx_s* ctx_;
  int level_;
};

class ZstdDecompressor {
 public:
  ZstdDecompressor();
  ~ZstdDecompressor();
  ZstdDecompressor(const ZstdDecompressor&) = delete;
  ZstdDecompressor& operator=(const ZstdDecompressor&) = delete;

  // Decodes one frame into exactly dst.size() bytes. A frame that is
  // damaged, of another size, or fails its checksum is Corruption; `what`
  // names the block in the message ("store.sdb: block 12").
  Status Decompress(std::span<const uint8_t> src, std::span<uint8_t> dst, std::string_view what);

 private:
  ZSTD_DCtx_s* ctx_;
};

}  // namespace simplexdb
