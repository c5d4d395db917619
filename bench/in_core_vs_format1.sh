#!/usr/bin/env bash
# In-core query rate of today's store against format 1's (issue 16's in-core
# target). Format 1 is no longer in the tree, so this builds query_bench as
# it was at 0fff0fc (the commit of format 1's RESULTS.md) in a git worktree,
# then runs the two binaries in turn, ROUNDS times: depth-first at 1% of the
# range over the in-memory store, HT 129^3 and HP 33^4 Perlin noise. Each
# round prints both rates and their ratio; taking them in turn keeps the
# ratio meaningful while this machine's speed drifts.
#
#   bench/in_core_vs_format1.sh [WORKDIR] [ROUNDS]   (default: a temporary
#                                                     directory, 3 rounds)
#
# Needs build/release and a few minutes to build the old binary (ccache
# helps).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT="$PWD"
WORK="${1:-$(mktemp -d)}"
ROUNDS="${2:-3}"
mkdir -p "$WORK"
[[ $# -ge 1 ]] || trap 'git -C "$ROOT" worktree remove --force "$WORK/format1" 2>/dev/null; rm -rf "$WORK"' EXIT

OLD="$WORK/format1"
if [[ ! -x "$OLD/build/release/bench/query_bench" ]]; then
  [[ -d "$OLD" ]] || git -C "$ROOT" worktree add --detach "$OLD" 0fff0fc
  launcher=()
  command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  (cd "$OLD" && cmake --preset release "${launcher[@]}" > /dev/null &&
    cmake --build --preset release --target query_bench > /dev/null)
fi
cmake --build "$ROOT/build/release" --target query_bench > /dev/null

filter='Extract/(ht129|hp33)/in-memory/depth-first'
rates() {  # binary -> "ht129 RATE hp33 RATE" in M splits/s
  (cd "$WORK" && "$1" --benchmark_filter="$filter" --benchmark_format=json 2> /dev/null) |
    /usr/bin/python3 -c '
import json, sys
for b in json.load(sys.stdin)["benchmarks"]:
    print(b["name"].split("/")[1], "%.2f" % (b["splits/s"] / 1e6), end=" ")
'
}
echo "round  hierarchy  format 1 (M splits/s)  today  today/format 1"
for ((r = 1; r <= ROUNDS; ++r)); do
  read -r _ f1_ht _ f1_hp <<< "$(rates "$OLD/build/release/bench/query_bench")"
  read -r _ f2_ht _ f2_hp <<< "$(rates "$ROOT/build/release/bench/query_bench")"
  for h in ht hp; do
    old="f1_$h" new="f2_$h"
    awk -v r="$r" -v h="$h" -v a="${!old}" -v b="${!new}" \
      'BEGIN { printf "%5d  %-9s  %21.2f  %5.2f  %14.2f\n", r, h, a, b, b / a }'
  done
done
