// gzip (RFC 1952) written by zlib for the volume tests, independent of the
// readers' inflate path: the compressed NRRD files the tests hand them.
#pragma once

#include <gtest/gtest.h>
#include <zlib.h>

#include <string>

namespace simplexdb::testing {

// `data` gzipped at zlib `level` (1..9) with `mem_level` (1..9) of memory.
inline std::string Gzip(const std::string& data, int level = 6, int mem_level = 8) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, level, Z_DEFLATED, 15 + 16 /* gzip wrapper */, mem_level, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&zs, data.size()) + 64, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

}  // namespace simplexdb::testing
