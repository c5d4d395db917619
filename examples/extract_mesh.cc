// extract_mesh STORE ERROR[%]: opens a SimplexDB store (dense .sdb or sparse
// LMDB, HT or HP), runs depth-first selective refinement to the error
// threshold (absolute, or in percent of the field range) and prints what it
// did. The smallest program that embeds the library: see CMakeLists.txt.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "query/criteria.h"
#include "query/mesh.h"
#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"

namespace {

using namespace simplexdb;

template <int D, class Source>
int Extract(Source& source, const std::string& threshold) {
  CriteriaSpec spec;
  spec.error.percent = !threshold.empty() && threshold.back() == '%';
  spec.error.value = std::strtod(threshold.c_str(), nullptr);
  const SourceInfo& info = source.info();
  Result<Criteria<D>> criteria = MakeCriteria<D>(spec, info.domain_bits, info.field_range());
  if (!criteria.ok()) {
    std::fprintf(stderr, "%s\n", criteria.status().ToString().c_str());
    return 2;
  }
  Refiner<D, Source> refiner(source, *criteria);
  Mesh<D> mesh;
  QueryStats stats;
  if (Status s = refiner.Run(RefineOptions{}, mesh, stats); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.ToString().c_str());
    return 1;
  }
  std::printf("{\"simplices\": %llu, \"splits\": %llu, \"seconds\": %.6f}\n",
              static_cast<unsigned long long>(stats.simplices),
              static_cast<unsigned long long>(stats.splits), stats.seconds);
  return 0;
}

template <class Store>
int Run(const Store& store, const std::string& threshold) {
  if constexpr (std::is_same_v<Store, DenseStore>) {
    if (store.header().dimension == 3) {
      DenseSource<3> source(store);
      return Extract<3>(source, threshold);
    }
    DenseSource<4> source(store);
    return Extract<4>(source, threshold);
  } else {
    if (store.dimension() == 3) {
      auto source = SparseSource<3>::Create(store);
      if (!source.ok()) return std::fprintf(stderr, "%s\n", source.status().ToString().c_str()), 1;
      return Extract<3>(*source, threshold);
    }
    auto source = SparseSource<4>::Create(store);
    if (!source.ok()) return std::fprintf(stderr, "%s\n", source.status().ToString().c_str()), 1;
    return Extract<4>(*source, threshold);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s STORE ERROR[%%]\n", argv[0]);
    return 2;
  }
  const std::string path = argv[1];
  if (LooksLikeLmdb(path)) {
    auto store = SparseStore::Open(path);
    if (!store.ok()) return std::fprintf(stderr, "%s\n", store.status().ToString().c_str()), 1;
    return Run(**store, argv[2]);
  }
  auto store = DenseStore::Open(path);
  if (!store.ok()) return std::fprintf(stderr, "%s\n", store.status().ToString().c_str()), 1;
  return Run(**store, argv[2]);
}
