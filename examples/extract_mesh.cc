// extract_mesh STORE ERROR[%]: opens a SimplexDB store (dense .sdb or sparse
// LMDB, HT or HP), runs depth-first selective refinement to the error
// threshold (absolute, or in percent of the field range) and prints what it
// did. The smallest program that embeds the library: see CMakeLists.txt.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "query/criteria.h"
#include "query/mesh.h"
#include "query/open_store.h"
#include "query/refine.h"
#include "query/source.h"

namespace {

using namespace simplexdb;

// The query, written once for every kind of store and both hierarchies:
// AnyStore::Visit calls it with the concrete source (static dispatch).
// `exit_code` is set for failures that are not the store's.
template <int D, class Source>
Status Extract(Source& source, const std::string& threshold, int& exit_code) {
  CriteriaSpec spec;
  spec.error.percent = !threshold.empty() && threshold.back() == '%';
  spec.error.value = std::strtod(threshold.c_str(), nullptr);
  const SourceInfo& info = source.info();
  Result<Criteria<D>> criteria = MakeCriteria<D>(spec, info.domain_bits, info.field_range());
  if (!criteria.ok()) {
    exit_code = 2;
    return criteria.status();
  }
  Refiner<D, Source> refiner(source, *criteria);
  Mesh<D> mesh;
  QueryStats stats;
  SDB_RETURN_IF_ERROR(refiner.Run(RefineOptions{}, mesh, stats));
  std::printf("{\"simplices\": %llu, \"splits\": %llu, \"seconds\": %.6f}\n",
              static_cast<unsigned long long>(stats.simplices),
              static_cast<unsigned long long>(stats.splits), stats.seconds);
  return Status::OK();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s STORE ERROR[%%]\n", argv[0]);
    return 2;
  }
  const std::string threshold = argv[2];
  int exit_code = 1;
  const Status s = VisitStore(argv[1], StoreOptions{}, [&]<int D, class Source>(Source& source) {
    return Extract<D>(source, threshold, exit_code);
  });
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.ToString().c_str());
    return exit_code;
  }
  return 0;
}
