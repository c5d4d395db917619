// A dense HT store of a smooth generated field for the tests of readers that
// share blocks (threads, processes, a shared cache): blocks compress, so
// reads decode them; every internal node's error bound, read from the store
// alone, is what a reader must see again.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"

namespace simplexdb::testing {

struct SmoothHtStore {
  std::string path;             // FOLDER/NAME.sdb
  std::vector<TetCode> codes;   // every internal node, depth first
  std::vector<double> expected; // codes[k]'s error bound

  // Builds FOLDER/NAME.sdb from a side^3 field of `seed` rounded to uint8,
  // in blocks of 2^block_bits errors, and reads every bound back through a
  // private cache.
  SmoothHtStore(const std::string& folder, const std::string& name, uint32_t side, uint64_t seed,
                int block_bits) {
    GenerateOptions g;
    g.dims = {side, side, side, 1};
    g.seed = seed;
    const FieldGenerator field(g);
    std::vector<double> values(uint64_t{side} * side * side);
    field.Fill(0, values.size(), values.data());
    for (double& v : values) v = std::round(v);
    const std::string nrrd = folder + "/" + name + ".nrrd";
    EXPECT_TRUE(WriteNrrd(nrrd, 3, g.dims, VoxelType::kU8, values).ok());
    DenseBuildOptions options;
    options.block_bits = block_bits;
    path = folder + "/" + name + ".sdb";
    EXPECT_TRUE(BuildDenseStore(*OpenVolume(nrrd), path, options).ok());
    auto store = *DenseStore::Open(path);
    DenseStore::Reader<3> reader(*store);
    std::function<void(TetCode)> visit = [&](TetCode c) {
      if (c.level() >= store->header().leaf_level()) return;
      codes.push_back(c);
      expected.push_back(*reader.ErrorBound(c));
      visit(c.child(0));
      visit(c.child(1));
    };
    for (int top = 0; top < 6; ++top) visit(TetCode::Root(top));
  }
};

}  // namespace simplexdb::testing
