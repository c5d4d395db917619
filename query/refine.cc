#include "query/refine.h"

namespace simplexdb {

const char* AlgorithmName(Algorithm a) {
  switch (a) {
    case Algorithm::kDepthFirst:
      return "depth-first";
    case Algorithm::kPriority:
      return "priority";
    case Algorithm::kIncremental:
      return "incremental";
    case Algorithm::kSaturated:
      return "saturated";
    case Algorithm::kLevelOrder:
      return "level-order";
  }
  return "?";
}

Result<Algorithm> ParseAlgorithm(std::string_view text) {
  for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kIncremental,
                      Algorithm::kSaturated, Algorithm::kLevelOrder}) {
    if (text == AlgorithmName(a)) return a;
  }
  return Status::InvalidArgument("algorithm '" + std::string(text) +
                                 "': expected depth-first, priority, incremental, saturated or level-order");
}

}  // namespace simplexdb
