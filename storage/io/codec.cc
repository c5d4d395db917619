#include "storage/io/codec.h"

#include <zstd.h>

#include <string>

namespace simplexdb {

ZstdCompressor::ZstdCompressor(int level) : ctx_(ZSTD_createCCtx()), level_(level) {}

ZstdCompressor::~ZstdCompressor() { ZSTD_freeCCtx(ctx_); }

Result<std::vector<uint8_t>> ZstdCompressor::Compress(std::span<const uint8_t> src) {
  if (ctx_ == nullptr) return Status::ResourceExhausted("zstd: cannot allocate a context");
  ZSTD_CCtx_reset(ctx_, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(ctx_, ZSTD_c_compressionLevel, level_);
  ZSTD_CCtx_setParameter(ctx_, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(ctx_, ZSTD_c_contentSizeFlag, 1);
  std::vector<uint8_t> out(ZSTD_compressBound(src.size()));
  const size_t n = ZSTD_compress2(ctx_, out.data(), out.size(), src.data(), src.size());
  if (ZSTD_isError(n)) {
    return Status::IOError(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
  }
  out.resize(n);
  return out;
}

ZstdDecompressor::ZstdDecompressor() : ctx_(ZSTD_createDCtx()) {}

ZstdDecompressor::~ZstdDecompressor() { ZSTD_freeDCtx(ctx_); }

Status ZstdDecompressor::Decompress(std::span<const uint8_t> src, std::span<uint8_t> dst,
                                    std::string_view what) {
  if (ctx_ == nullptr) return Status::ResourceExhausted("zstd: cannot allocate a context");
  // The frame must say it holds exactly dst.size() bytes and be one frame.
  const unsigned long long declared = ZSTD_getFrameContentSize(src.data(), src.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN ||
      declared != dst.size() || ZSTD_findFrameCompressedSize(src.data(), src.size()) != src.size()) {
    return Status::Corruption(std::string(what) + ": not a zstd frame of " +
                              std::to_string(dst.size()) + " bytes");
  }
  const size_t n = ZSTD_decompressDCtx(ctx_, dst.data(), dst.size(), src.data(), src.size());
  if (ZSTD_isError(n) || n != dst.size()) {
    return Status::Corruption(std::string(what) + ": zstd frame does not decode" +
                              (ZSTD_isError(n) ? std::string(": ") + ZSTD_getErrorName(n) : ""));
  }
  return Status::OK();
}

}  // namespace simplexdb
