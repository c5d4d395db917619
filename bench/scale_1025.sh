#!/usr/bin/env bash
# The dense store's scale run: a 1025^3 Perlin volume (1.08 billion grid
# points, about 6.4 billion tetrahedra) built into an HT store with the
# builder's memory bounded to 14 GiB (the dense store is built in memory for
# now: the field as doubles and a float per vertex, 12.3 GiB; streaming
# within a smaller bound is issue 16's remaining work). Prints the build report (time, peak
# memory) and the store's info (size), and fails if the peak resident memory
# exceeds the bound. Then a reader does a million random lookups with a 64
# MiB cache (tests/storage/dense/memory_probe.cc) and prints its anonymous memory;
# fails if it grew by more than the budget plus 16 MiB.
#
#   bench/scale_1025.sh [WORK_DIR]     (needs ~2 GB of disk and 14 GiB of memory)
#
# Also ctest's ScaleBuild1025 (label "long", not in the default suite).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
simplexdb=${SIMPLEXDB:-build/release/tools/simplexdb}
probe=${MEMORY_PROBE:-build/release/tests/memory_probe}
work=${1:-$(mktemp -d)}
limit_mb=14336
mkdir -p "$work"
trap 'rm -f "$work/perlin1025.nrrd" "$work/perlin1025.sdb"' EXIT
start=$(date +%s)
"$simplexdb" generate --field perlin --dims 1025,1025,1025 --type uint8 -q -o "$work/perlin1025.nrrd"
echo "generated in $(( $(date +%s) - start )) s" >&2
report=$("$simplexdb" import "$work/perlin1025.nrrd" -o "$work/perlin1025.sdb" \
         --memory-mb "$limit_mb" --json -q)
echo "$report"
"$simplexdb" info "$work/perlin1025.sdb" --json
peak=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["peak_memory_bytes"])' "$report")
if (( peak > limit_mb * 1024 * 1024 )); then
  echo "peak memory $peak bytes exceeds the ${limit_mb} MiB bound" >&2
  exit 1
fi
budget=$((64 << 20))
read -r before after decoded < <("$probe" "$work/perlin1025.sdb" "$budget" 1000000 |
  sed -E 's/[a-z_]+=//g')
echo "reader: 1000000 random lookups, cache budget 64 MiB: anonymous memory $before KiB -> $after KiB, $decoded blocks decoded"
if (( after - before > (budget >> 10) + 16384 )); then
  echo "the reader's anonymous memory grew by $(( after - before )) KiB" >&2
  exit 1
fi
